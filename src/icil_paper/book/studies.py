"""Experiments that a chapter and `icil-paper reproduce` share: each runs what the store
lacks (`ResultsStore.run`, so a second call only loads) and returns the metrics by label;
`SeedRecords` summarises them over training seeds.

    seeds = SeedRecords(tokenizer_study(preset, store))    # {label: [metrics per seed]}
    seeds.mean("lipvq", "usage")                            # mean over training seeds
    seeds.with_interval("lipvq", "least_energy")            # "0.012 [0.01, 0.014]"
    seeds.seed_means()                                      # one row of means per label
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper import sim, stats
from icil_paper.config import Preset, TokenizerStudyConfig
from icil_paper.config_data import to_dict
from icil_paper.data import SOURCES, ensure_many, load_demos, preset_tasks
from icil_paper.data.experts import measure
from icil_paper.data.showcase import showcase_task
from icil_paper.data.trajectories import generate_trajectories
from icil_paper.metrics import empirical_lipschitz
from icil_paper.registry import check_name
from icil_paper.results import ResultsStore, config_hash, results_root
from icil_paper.runspec import SUITE_VERSION, DataSpec
from icil_paper.seeding import seed_everything
from icil_paper.sim import ACTION_DIM
from icil_paper.tokenizers import TOKENIZERS, lipschitz_bounds, lipschitz_loss, make_tokenizer
from icil_paper.tokenizers.configs import TokenizerConfig, lipvq_official
from icil_paper.tokenizers.lipschitz_linear import weight_norm_bound
from icil_paper.tokenizers.training import (
    evaluate_tokenizer,
    reconstruction_errors,
    smoothness,
    stand_alone,
    train_tokenizer,
)
from icil_paper.viz.recording import principal_view, record_latent_trajectories

VIEW_STEPS = 40
"""Steps of one held-out trajectory kept (in principal components) for latent plots."""
VIEW_DIMS = 3
"""Principal components of that latent trajectory kept (the figure draws 2, rerun 3)."""


@dataclass(frozen=True)
class TokenizerStudySpec:
    """One tokenizer trained alone and measured (chapters 03 and 05): its key's content."""

    tokenizer: TokenizerConfig
    """The tokenizer's config (with `autoencode` where it has one: trained alone)."""
    study: TokenizerStudyConfig
    """Steps, batches, learning rate and the trajectories it is trained on."""
    data: DataSpec
    """The demonstrations whose actions are the trajectories (with `trajectories="demos"`)."""
    seed: int
    """Training seed."""
    view_steps: int = VIEW_STEPS
    """Steps of the held-out trajectory kept for latent plots."""
    view_dims: int = VIEW_DIMS
    """Principal components kept of it."""
    radii: tuple[float, ...] = ()
    """Chapter 03: perturbation radii of the empirical Lipschitz estimates (empty: none)."""


def tokenizer_runs(preset: Preset) -> list[tuple[str, TokenizerConfig]]:
    """(label, config): every tokenizer of the preset, the official code's LipVQ, and VQ-VAE
    and LipVQ-VAE with codes initialised from encoder outputs (`codebook_init="data"`)."""
    t = preset.tokenizers
    return [(name, t.get(name)) for name in TOKENIZERS] + [
        ("lipvq-official", lipvq_official(t.lipvq.latent_dim, t.lipvq.codebook_size)),
        ("vq-data-init", dataclasses.replace(t.vq, codebook_init="data")),
        ("lipvq-data-init", dataclasses.replace(t.lipvq, codebook_init="data"))]


def study_data(preset: Preset) -> DataSpec:
    """The demonstrations tokenizers are trained on alone (generated, state)."""
    return DataSpec(tasks=tuple(preset.data.robocasa_tasks) + tuple(preset.data.maniskill_tasks),
                    source="generated", obs="state", demos_per_task=preset.data.demos_per_task,
                    seed=preset.seed)


def study_spec(preset: Preset, config: TokenizerConfig, radii: tuple[float, ...] = (),
               seed_index: int = 0) -> TokenizerStudySpec:
    return TokenizerStudySpec(tokenizer=stand_alone(config), study=preset.tokenizer_study,
                              data=study_data(preset), seed=preset.seed + seed_index,
                              radii=tuple(radii))


def seeded_study_specs(preset: Preset, runs: list[tuple[str, TokenizerConfig]],
                       radii: tuple[float, ...] = ()) -> list[tuple[str, TokenizerStudySpec]]:
    """(label, spec) of every run of a stand-alone study at each training seed, in order."""
    return [(label, study_spec(preset, config, radii, s)) for label, config in runs
            for s in range(preset.tokenizer_study.seeds)]


def tokenizer_trajectories(preset: Preset) -> tuple[list[np.ndarray], list[np.ndarray], dict]:
    """(train, test, description): the action trajectories tokenizers are trained on alone:
    the actions of `study_data`'s demos, the last `eval_fraction` of each task's held out
    ("demos"), or minimum-jerk trajectories ("synthetic")."""
    cfg = preset.tokenizer_study
    kind = check_name("tokenizer trajectories", cfg.trajectories, ("demos", "synthetic"))
    if kind == "synthetic":
        train = generate_trajectories(cfg.n_trajectories, seed=preset.seed,
                                      noise=cfg.trajectory_noise)
        test = generate_trajectories(cfg.n_eval_trajectories, seed=preset.seed + 1,
                                     noise=cfg.trajectory_noise)
        return train, test, {"kind": kind, "generator": "icil_paper.data.trajectories",
                             "n": cfg.n_trajectories, "n_eval": cfg.n_eval_trajectories,
                             "noise": cfg.trajectory_noise}

    data = study_data(preset)
    tasks = list(data.tasks)
    paths = ensure_many(preset, tasks, ["generated"], n=data.demos_per_task, seed=data.seed)
    train, test = [], []
    for task in tasks:
        demos = load_demos(paths[task, "generated"], action_dim=ACTION_DIM,
                           limit=preset.data.demos_per_task, images=False)
        if len(demos) < 2:
            raise ValueError(f"{task}: {len(demos)} demo(s); holding some out for the tokenizer "
                             f"metrics needs at least 2 (raise data.demos_per_task)")
        n_test = min(len(demos) - 1, max(1, round(cfg.eval_fraction * len(demos))))
        actions = [d.actions.astype(np.float32) for d in demos]
        train += actions[:-n_test]
        test += actions[-n_test:]
    return train, test, {"kind": kind, "source": "generated", "tasks": tasks,
                         "demos_per_task": preset.data.demos_per_task,
                         "eval_fraction": cfg.eval_fraction, "data_seed": preset.seed}


def _train_alone(preset: Preset, spec: TokenizerStudySpec):
    """Train one tokenizer alone; return it, its training log and the test trajectories."""
    train, test, _ = tokenizer_trajectories(preset)
    seed_everything(spec.seed)
    tok = make_tokenizer(spec.tokenizer, ACTION_DIM)
    result = train_tokenizer(tok, train, spec.study, seed=spec.seed, progress=True)
    return tok, result, test


def _train_and_measure_tokenizer(preset: Preset, spec: TokenizerStudySpec) -> dict:
    import torch

    tok, result, test = _train_alone(preset, spec)
    # throughput does not depend on the weights: timed for the first seed only
    metrics = evaluate_tokenizer(tok, test, seed=spec.seed, timing=spec.seed == preset.seed)
    metrics["train_s"] = result["wall_time_s"]
    metrics["final_loss"] = result["history"]["loss"][-1]
    # One held-out latent trajectory in principal components, for the chapter's figure and
    # its rerun recording (`tokenizer_latent_recording`).
    with torch.no_grad():
        z = tok.eval()(torch.from_numpy(test[0][None, :spec.view_steps])).embeddings[0].numpy()
    metrics["latent_view"] = principal_view(z, spec.view_dims).tolist()
    return metrics


def tokenizer_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, list[dict]]:
    """Chapter 05: every tokenizer trained alone and measured, {label: [metrics per seed]}."""
    return _seeded_study(preset, store, "tokenizer", seeded_study_specs(
        preset, tokenizer_runs(preset)), _train_and_measure_tokenizer, force)


def _seeded_study(preset: Preset, store: ResultsStore | None, kind: str, specs, measure,
                  force: bool) -> dict[str, list[dict]]:
    store = store or ResultsStore(preset.name)
    records: dict[str, list[dict]] = {}
    for label, spec in specs:
        records.setdefault(label, []).append(store.run(
            kind, f"{label}__seed{spec.seed}", to_dict(spec, keyed_only=True),
            lambda spec=spec: measure(preset, spec), seed=spec.seed, force=force)["metrics"])
    return records


def tokenizer_latent_recording(preset: Preset, records: dict[str, dict]) -> dict:
    """Chapter 05: every tokenizer's stored `latent_view` as one recording; returns its paths."""
    _, test, _ = tokenizer_trajectories(preset)
    actions = test[0][:VIEW_STEPS]
    views = {label: np.asarray(m[0]["latent_view"])[:len(actions)]  # seed 0's tokenizers
             for label, m in records.items()}
    title = (f"First {len(actions)} steps of one held-out trajectory in each latent space "
             "(principal components, each path scaled to unit extent; colour = time)")
    return record_latent_trajectories(
        results_root() / preset.name / "tokenizers" / "latent_trajectories.rrd", actions, views,
        title=title)


def lipschitz_models(preset: Preset) -> list[tuple[str, TokenizerConfig]]:
    """Encoders compared in chapter 03: (label, config)."""
    t = preset.tokenizers
    return [("lipvq (paper)", t.lipvq),
            ("lipvq (official code)", lipvq_official(t.lipvq.latent_dim, t.lipvq.codebook_size)),
            ("vq + spectral norm", dataclasses.replace(t.vq, norm="spectral")),
            ("vq (no normalization)", t.vq)]


LIPSCHITZ_RADII = (1e-3, 1e-2, 1e-1, 1.0)
"""Perturbation radii of the random pairs that estimate an empirical Lipschitz constant."""


def _lipschitz_measurements(preset: Preset, spec: TokenizerStudySpec) -> dict:
    import torch

    tok, result, test = _train_alone(preset, spec)
    anchors = torch.from_numpy(np.concatenate(test))
    metrics = {
        "bound_inf": weight_norm_bound(tok.encoder, math.inf),
        "bound_2": weight_norm_bound(tok.encoder, 2),
        "bound_softplus_product": (lipschitz_loss(tok.encoder).item()
                                   if lipschitz_bounds(tok) else None),
        "c_history": result["history"]["lipschitz_bounds"],
        "history_step": result["history"]["step"],
        "train_s": result["wall_time_s"],
    }
    for radius in spec.radii:
        for ord_name, ord_value in (("inf", math.inf), ("2", 2)):
            metrics[f"empirical_{ord_name}_r{radius:g}"] = empirical_lipschitz(
                tok.encoder, anchors, n_pairs=4000, radius=radius, seed=spec.seed,
                ord=ord_value)
    metrics.update(reconstruction_errors(tok, test))
    metrics.update({k if k.startswith("latent") else f"latent_{k}": v
                    for k, v in smoothness(tok, test).items()})
    return metrics


def lipschitz_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, dict]:
    """Chapter 03: encoders' bounds vs empirical constants, {label: [metrics per seed]}."""
    return _seeded_study(preset, store, "lipschitz", seeded_study_specs(
        preset, lipschitz_models(preset), LIPSCHITZ_RADII), _lipschitz_measurements, force)


def shown_tasks(preset: Preset) -> list[str]:
    """Chapter 04's tasks: every task the preset's tables evaluate on (not the zero-shot
    table's 45 training tasks), or one per suite under the smoke preset."""
    if preset.name == "smoke":
        return [t for t in ("metaworld/drawer-open", "kinova/open_drawer", "maniskill/pick_cube")
                if t in sim.all_tasks()]
    trained_only = set(preset.data.zero_shot_tasks) - set(preset.data.robocasa_tasks)
    return [t for t in preset_tasks(preset, available=True) if t not in trained_only]


@dataclass(frozen=True)
class ShowcaseSpec:
    """What a task's showcase (a rendered frame and a recorded demo 0) depends on."""

    task: str
    """The task shown."""
    seed: int
    """Base seed of the scene and of demo 0."""
    files: tuple[str, ...] = ("frame.png", "rrd", "png")
    """The files written: the frame, the rerun recording and its static picture."""
    suite_version: int = SUITE_VERSION
    """The task suites' version the scene is drawn from (`runspec.SUITE_VERSION`)."""


def showcase_study(preset: Preset, store: ResultsStore | None = None,
                   force: bool = False) -> dict[str, dict]:
    """Chapter 04: a rendered frame and a recorded demo 0 of every shown task, by task."""
    store = store or ResultsStore(preset.name)
    out_dir = results_root() / preset.name / "showcase"
    shown = {}
    for task in shown_tasks(preset):
        spec = ShowcaseSpec(task=task, seed=preset.seed)
        compute = lambda task=task: showcase_task(task, out_dir, preset.seed)  # noqa: E731
        metrics = store.run("showcase", task, to_dict(spec), compute, seed=preset.seed,
                            force=force)["metrics"]
        if not all(Path(metrics[k]).exists() for k in ("frame", "picture")):
            metrics = store.run("showcase", task, to_dict(spec), compute, seed=preset.seed,
                                force=True)["metrics"]
        shown[task] = metrics
    return shown


def expert_study(preset: Preset, store: ResultsStore | None = None,
                 force: bool = False) -> dict[str, dict]:
    """Every expert's success over `preset.data.expert_seeds` random scenes, by suite."""
    store = store or ResultsStore(preset.name)
    n_seeds = preset.data.expert_seeds
    if n_seeds <= 0:
        return {}
    records = {}
    for suite in sim.SUITES:
        if sim.suite_unavailable(suite):
            continue
        config = {"suite": suite, "n_seeds": n_seeds, "seed": preset.seed, "human": True,
                  "tasks": list(sim.tasks_of(suite))}
        if sim.get_suite(suite).scenes:  # the expert is measured on each scene distribution
            config["scenes"] = list(sim.get_suite(suite).scenes)
        records[suite] = store.run(
            "experts", suite, config,
            lambda suite=suite: measure(suite, n_seeds, preset.seed, preset.data.workers),
            seed=preset.seed, force=force)["metrics"]
    return records


def expert_measurements(preset: Preset, store: ResultsStore | None = None) -> list[dict]:
    """One row per task of every expert measurement: this preset's, else
    `results/experts/<suite>.json`, else the committed `results/bench/experts-<suite>.json`."""
    measured = {suite: {"tasks": record["tasks"], "commit": "this preset's store"}
                for suite, record in expert_study(preset, store).items()}
    for suite in sim.SUITES:
        path = results_root() / "experts" / f"{suite}.json"
        if not path.exists():  # the measurement committed with the repository
            path = results_root() / "bench" / f"experts-{suite}.json"
        if suite not in measured and path.exists():
            record = json.loads(path.read_text())
            measured[suite] = {"tasks": record["tasks"],
                               "commit": (record.get("git_commit") or "")[:8]}
    return [{"task": task, "seeds": entry["episodes"], "expert": entry["expert_success_rate"],
             "expert, human scenes": entry.get("expert_success_rate_human_scenes"),
             "replay": entry.get("replay_success_rate"),
             "human kept": entry.get("human_success_rate"),
             "mean length": entry["mean_length"], "from": record["commit"]}
            for record in measured.values() for task, entry in record["tasks"].items()]


def demo_stage(preset: Preset, store: ResultsStore | None = None, force: bool = False) -> dict:
    """Make every data set of the preset; return their paths (generation is resumable)."""
    tasks = preset_tasks(preset, available=True)
    # the zero-shot table's training tasks need no human-like source (only Table VI reads it)
    generated_only = set(preset.data.zero_shot_tasks) - set(preset.data.robocasa_tasks)
    paths = ensure_many(preset, [t for t in tasks if t not in generated_only], SOURCES)
    zero_shot = [t for t in tasks if t in generated_only]
    if zero_shot:
        paths.update(ensure_many(preset, zero_shot, ("generated",)))
    return paths


def study_keys(preset: Preset) -> dict[str, set[str]]:
    """{kind: keys} of the records the chapters' own studies compute at the preset."""
    def hashes(specs) -> set[str]:
        return {config_hash(to_dict(spec, keyed_only=True)) for _, spec in specs}

    return {"tokenizer": hashes(seeded_study_specs(preset, tokenizer_runs(preset))),
            "lipschitz": hashes(seeded_study_specs(preset, lipschitz_models(preset),
                                                   LIPSCHITZ_RADII)),
            "showcase": {config_hash(to_dict(ShowcaseSpec(task=task, seed=preset.seed)))
                         for task in shown_tasks(preset)}}


class SeedRecords:
    """A study's records, {label: [metrics of each training seed]}, summarised over seeds."""

    def __init__(self, records: Mapping[str, Sequence[Mapping[str, Any]]]):
        self.records = {label: list(ms) for label, ms in records.items()}
        empty = [label for label, ms in self.records.items() if not ms]
        if empty:
            raise ValueError(f"no seed's record for {empty}: run the study first")

    @property
    def n_seeds(self) -> int:
        """Training seeds of the first label (every label of a study has the same)."""
        return len(next(iter(self.records.values()))) if self.records else 0

    def mean(self, label: str, key: str) -> float | None:
        """The mean of `key` over the seeds that recorded it (None where none did)."""
        values = [m[key] for m in self.records[label] if m.get(key) is not None]
        return float(np.mean(values)) if values else None

    def per_level(self, label: str) -> str | None:
        """Residual VQ: the codes each level uses, mean over seeds ("8 / 7"); None otherwise."""
        levels = [m["codes_used_per_level"] for m in self.records[label]
                  if m.get("codes_used_per_level")]
        return " / ".join(f"{v:.0f}" for v in np.mean(levels, axis=0)) if levels else None

    def scores(self, label: str, key: str) -> np.ndarray:
        """(seeds, trajectories) per-trajectory scores of `key` (`<key>_per_trajectory`)."""
        return np.array([m[f"{key}_per_trajectory"] for m in self.records[label]], dtype=float)

    def with_interval(self, label: str, key: str, digits: int = 3) -> str:
        """The mean score with its 95% interval (`stats.score_mean`), as text."""
        est = stats.score_mean(self.scores(label, key))
        return f"{est.value:.{digits}g} [{est.low:.{digits}g}, {est.high:.{digits}g}]"

    def seed_means(self) -> dict[str, dict[str, Any]]:
        """One row per label: the mean over seeds of every number, seed 0's value otherwise."""
        return {label: {k: float(np.mean([m[k] for m in ms])) if isinstance(v, (int, float))
                        else v for k, v in ms[0].items()}
                for label, ms in self.records.items()}
