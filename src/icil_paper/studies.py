"""Experiments that a chapter and `icil-paper reproduce` share.

Each study takes a preset and a results store, runs what is missing through
`ResultsStore.run` (so a second call only loads) and returns the metrics by run label.
`reproduce` calls them to fill the store; the notebooks call them again to draw.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from icil_paper.config import Preset
from icil_paper.recording import principal_view
from icil_paper.results import ResultsStore
from icil_paper.sim import ACTION_DIM

VIEW_STEPS = 40
"""Steps of one held-out trajectory kept (in principal components) for latent plots."""
VIEW_DIMS = 3
"""Principal components of that latent trajectory kept (the figure draws 2, rerun 3)."""


def tokenizer_runs() -> list[tuple[str, str, dict]]:
    """(label, registry name, options): every tokenizer, the official code's LipVQ, and
    VQ-VAE and LipVQ-VAE with codes initialised from encoder outputs (`codebook_init="data"`,
    an opt-in remedy for codebook collapse, not the paper's method), so that chapter 04 can
    tell smoothness that comes from the Lipschitz bound from smoothness that comes from a
    trajectory that stays on one code."""
    from icil_paper.tokenizers import TOKENIZERS

    return [(name, name, {}) for name in TOKENIZERS] + [
        ("lipvq-official", "lipvq", {"variant": "official"}),
        ("vq-data-init", "vq", {"codebook_init": "data"}),
        ("lipvq-data-init", "lipvq", {"codebook_init": "data"})]


def tokenizer_trajectories(preset: Preset) -> tuple[list[np.ndarray], list[np.ndarray], dict]:
    """The (train, test) action trajectories tokenizers are trained on alone, and what they are.

    With `preset.tokenizer.trajectories == "demos"`: the actions of the preset's `generated`
    demonstrations of its kitchen and ManiSkill tasks (made if missing), the last
    `eval_fraction` of each task's demos (at least one) held out. With `"synthetic"`:
    minimum-jerk trajectories from `icil_paper.trajectories`. The returned dict describes the
    choice and goes into every record's config.
    """
    from icil_paper.registry import check_name

    cfg = preset.tokenizer
    kind = check_name("tokenizer trajectories", cfg.trajectories, ("demos", "synthetic"))
    if kind == "synthetic":
        from icil_paper.trajectories import generate_trajectories

        train = generate_trajectories(cfg.n_trajectories, seed=preset.seed,
                                      noise=cfg.trajectory_noise)
        test = generate_trajectories(cfg.n_eval_trajectories, seed=preset.seed + 1,
                                     noise=cfg.trajectory_noise)
        return train, test, {"kind": kind, "generator": "icil_paper.trajectories",
                             "n": cfg.n_trajectories, "n_eval": cfg.n_eval_trajectories,
                             "noise": cfg.trajectory_noise}
    from icil_paper.data import ensure_many, load_demos

    tasks = list(preset.data.kitchen_tasks) + list(preset.data.maniskill_tasks)
    paths = ensure_many(preset, tasks, ["generated"])
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


def _train_alone(preset: Preset, name: str, options: dict):
    """Seed, load train/test trajectories, train one tokenizer alone; return it, log, test set."""
    from icil_paper.seeding import seed_everything
    from icil_paper.tokenizers.training import build_tokenizer, train_tokenizer

    train, test, _ = tokenizer_trajectories(preset)
    seed_everything(preset.seed)
    tok = build_tokenizer(name, ACTION_DIM, preset.tokenizer, stand_alone=True, **options)
    result = train_tokenizer(tok, train, preset.tokenizer, seed=preset.seed, progress=True)
    return tok, result, test


def _trajectory_config(preset: Preset) -> dict:
    """What the tokenizer studies' trajectories are, without loading them (for config hashes)."""
    cfg = preset.tokenizer
    if cfg.trajectories == "synthetic":
        return {"kind": "synthetic", "n": cfg.n_trajectories, "n_eval": cfg.n_eval_trajectories,
                "noise": cfg.trajectory_noise}
    return {"kind": cfg.trajectories, "source": "generated",
            "tasks": list(preset.data.kitchen_tasks) + list(preset.data.maniskill_tasks),
            "demos_per_task": preset.data.demos_per_task, "data_seed": preset.seed}


def _train_and_measure_tokenizer(preset: Preset, name: str, options: dict) -> dict:
    import torch

    from icil_paper.tokenizers.training import evaluate_tokenizer

    tok, result, test = _train_alone(preset, name, options)
    metrics = evaluate_tokenizer(tok, test, seed=preset.seed)
    metrics["train_s"] = result["wall_time_s"]
    metrics["final_loss"] = result["history"]["loss"][-1]
    # One held-out latent trajectory in principal components, for the chapter's figure and
    # its rerun recording (`tokenizer_latent_recording`).
    with torch.no_grad():
        z = tok.eval()(torch.from_numpy(test[0][None, :VIEW_STEPS])).embeddings[0].numpy()
    metrics["latent_view"] = principal_view(z, VIEW_DIMS).tolist()
    return metrics


def tokenizer_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, dict]:
    """Chapter 04: train every tokenizer alone on action trajectories and measure it."""
    store = store or ResultsStore(preset.name)
    records = {}
    for label, name, options in tokenizer_runs():
        config = {"chapter": "04", "tokenizer": name, "options": options,
                  "tokenizer_config": dataclasses.asdict(preset.tokenizer),
                  "seed": preset.seed, "trajectories": _trajectory_config(preset),
                  "latent_view": {"steps": VIEW_STEPS, "dims": VIEW_DIMS}}
        records[label] = store.run(
            "tokenizer", label, config,
            lambda name=name, options=options: _train_and_measure_tokenizer(preset, name, options),
            seed=preset.seed, force=force)["metrics"]
    return records


def tokenizer_latent_recording(preset: Preset, records: dict[str, dict]) -> dict:
    """Chapter 04: the held-out trajectory of `records["..."]["latent_view"]` through every
    tokenizer's latent space, as a rerun recording and its static picture.

    Written to `results/<preset>/chapter04/latent_trajectories.{rrd,png}` from the stored
    views and the trajectory's actions (no tokenizer is retrained); returns their paths.
    """
    from icil_paper.recording import record_latent_trajectories
    from icil_paper.results import results_root

    _, test, _ = tokenizer_trajectories(preset)
    actions = test[0][:VIEW_STEPS]
    views = {label: np.asarray(m["latent_view"])[:len(actions)] for label, m in records.items()}
    title = (f"First {len(actions)} steps of one held-out trajectory in each latent space "
             "(principal components, each path scaled to unit extent; colour = time)")
    return record_latent_trajectories(
        results_root() / preset.name / "chapter04" / "latent_trajectories.rrd", actions, views,
        title=title)


LIPSCHITZ_MODELS = (
    ("lipvq (paper)", "lipvq", {}),
    ("lipvq (official code)", "lipvq", {"variant": "official"}),
    ("vq + spectral norm", "vq", {"norm": "spectral"}),
    ("vq (no normalization)", "vq", {}),
)
"""Encoders compared in chapter 02: (label, tokenizer name, options)."""

LIPSCHITZ_RADII = (1e-3, 1e-2, 1e-1, 1.0)
"""Perturbation radii of the random pairs that estimate an empirical Lipschitz constant."""


def _lipschitz_measurements(preset: Preset, name: str, options: dict) -> dict:
    import math

    import torch

    from icil_paper.metrics import empirical_lipschitz
    from icil_paper.tokenizers import lipschitz_bounds, lipschitz_loss
    from icil_paper.tokenizers.lipschitz_linear import weight_norm_bound
    from icil_paper.tokenizers.training import reconstruction_errors, smoothness

    tok, result, test = _train_alone(preset, name, options)
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
    for radius in LIPSCHITZ_RADII:
        for ord_name, ord_value in (("inf", math.inf), ("2", 2)):
            metrics[f"empirical_{ord_name}_r{radius:g}"] = empirical_lipschitz(
                tok.encoder, anchors, n_pairs=4000, radius=radius, seed=preset.seed,
                ord=ord_value)
    metrics.update(reconstruction_errors(tok, test))
    metrics.update({f"latent_{k}": v for k, v in smoothness(tok, test).items()})
    return metrics


def lipschitz_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, dict]:
    """Chapter 02: train encoders with and without normalization; bounds vs empirical constants."""
    store = store or ResultsStore(preset.name)
    records = {}
    for label, name, options in LIPSCHITZ_MODELS:
        config = {"chapter": "02", "tokenizer": name, "options": options,
                  "tokenizer_config": dataclasses.asdict(preset.tokenizer), "seed": preset.seed,
                  "trajectories": _trajectory_config(preset),
                  "radii": list(LIPSCHITZ_RADII)}
        records[label] = store.run(
            "lipschitz", label, config,
            lambda name=name, options=options: _lipschitz_measurements(preset, name, options),
            seed=preset.seed, force=force)["metrics"]
    return records


ICRT_DEMO_TASK = "kitchen/open_drawer"
"""Chapter 01's task: one small ICRT trained and rolled out on it."""
ICRT_DEMO_TOKENIZER = "lipvq"
"""Chapter 01's action tokenizer (the paper's LipVQ-VAE)."""


def icrt_run_dir(preset: Preset):
    """Where chapter 01's policy is trained (checkpoints, metrics, policy.pt)."""
    from icil_paper.train import default_run_dir

    return default_run_dir(preset, "icrt", ICRT_DEMO_TOKENIZER, [ICRT_DEMO_TASK], "generated")


def icrt_rollout_study(preset: Preset, store: ResultsStore | None = None,
                       force: bool = False) -> dict:
    """Chapter 01: train a small ICRT + LipVQ-VAE on one task, then evaluate it from prompts.

    Returns the stored metrics: the loss curve, the training summary and the evaluation
    (success rate, Wilson interval, per-episode seeds and prompts).
    """
    import json

    from icil_paper.evaluate import evaluate_policy
    from icil_paper.train import METRICS_FILE, train_policy

    store = store or ResultsStore(preset.name)
    run_dir = icrt_run_dir(preset)
    config = {"chapter": "01", "policy": "icrt", "tokenizer": ICRT_DEMO_TOKENIZER,
              "task": ICRT_DEMO_TASK, "source": "generated", "prompt_source": "generated",
              "seed": preset.seed, "policy_config": preset.to_dict()["policy"],
              "train_config": preset.to_dict()["train"],
              "episodes": preset.eval.episodes_per_task, "max_steps": preset.eval.max_steps}

    def compute() -> dict:
        trained = train_policy(preset, "icrt", ICRT_DEMO_TOKENIZER, tasks=[ICRT_DEMO_TASK],
                               source="generated", run_dir=run_dir)
        lines = [json.loads(x) for x in (run_dir / METRICS_FILE).read_text().splitlines() if x]
        result = evaluate_policy(trained.policy, ICRT_DEMO_TASK, preset,
                                 prompt_source="generated",
                                 episodes=preset.eval.episodes_per_task, seed=preset.seed)
        return {"loss_steps": [x["step"] for x in lines], "loss": [x["loss"] for x in lines],
                "action_l1": [x["action_l1"] for x in lines], "train": trained.metrics,
                **{k: v for k, v in result.items() if k != "task"}}

    return store.run("chapter01", f"icrt+{ICRT_DEMO_TOKENIZER}__{ICRT_DEMO_TASK}", config,
                     compute, seed=preset.seed, force=force)["metrics"]


def shown_tasks(preset: Preset) -> list[str]:
    """Chapter 03's tasks: every task, or one per suite under the smoke preset."""
    from icil_paper import sim

    if preset.name == "smoke":
        return [t for t in ("kitchen/open_drawer", "kinova/open_drawer", "maniskill/pick_cube")
                if t in sim.all_tasks()]
    return list(sim.all_tasks())


def showcase_study(preset: Preset, store: ResultsStore | None = None,
                   force: bool = False) -> dict[str, dict]:
    """Chapter 03: a rendered frame and a recorded demo 0 of every shown task, by task.

    A record whose image files have gone missing is recomputed.
    """
    from pathlib import Path

    from icil_paper.data.showcase import showcase_task
    from icil_paper.results import results_root

    store = store or ResultsStore(preset.name)
    out_dir = results_root() / preset.name / "chapter03"
    shown = {}
    for task in shown_tasks(preset):
        config = {"task": task, "seed": preset.seed, "version": 2}
        compute = lambda task=task: showcase_task(task, out_dir, preset.seed)  # noqa: E731
        metrics = store.run("chapter03_task", task, config, compute, seed=preset.seed,
                            force=force)["metrics"]
        if not all(Path(metrics[k]).exists() for k in ("frame", "picture")):
            metrics = store.run("chapter03_task", task, config, compute, seed=preset.seed,
                                force=True)["metrics"]
        shown[task] = metrics
    return shown


def expert_study(preset: Preset, store: ResultsStore | None = None,
                 force: bool = False) -> dict[str, dict]:
    """Every expert's success over `preset.data.expert_seeds` random scenes, by suite.

    Nothing (an empty dict) when the preset sets `expert_seeds = 0`.
    """
    from icil_paper import sim
    from icil_paper.sim.measure_experts import measure

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
        records[suite] = store.run(
            "experts", suite, config,
            lambda suite=suite: measure(suite, n_seeds, preset.seed, preset.data.workers),
            seed=preset.seed, force=force)["metrics"]
    return records


def demo_stage(preset: Preset, store: ResultsStore | None = None, force: bool = False) -> dict:
    """Make every data set of the preset (all its tasks, both sources); return their paths.

    Generation is resumable and only adds what the files lack, so `force` does not apply:
    delete the files under `data/<preset>/` to regenerate them.
    """
    from icil_paper.data import SOURCES, ensure_many, preset_tasks

    return ensure_many(preset, preset_tasks(preset, available=True), SOURCES)
