"""Computing tables: the units of any set of tables grouped by trained run, fanned out.

    run_specs(preset, [table_spec(preset, "I")], executor="local", workers=2)
    # the paper's tables by id: icil_paper.paper.run_tables(preset, ["I", "VI"])

1. `plan` collects the units of the chosen tables and groups them by RunSpec key: one
   `RunPlan` per policy to train, with every evaluation and feature measurement any table
   asks of it (a policy shared by five tables is trained once and evaluated once per
   distinct EvalSpec).
2. The data sets every plan reads (training demonstrations, prompt pools, held-out
   trajectories) are generated first, in this process, with the preset's data workers.
3. Each RunPlan becomes one grid cell (`icil_paper.tables.grid`): `run_cell` trains the policy
   (or finds it), evaluates it and measures its features, writing one record per result
   through the results store. A cell whose records all exist is skipped, so a killed run
   resumes where it stopped. A grid worker keeps its environments from cell to cell
   (`keep_envs`), so it builds each task's env once (`python -m tools.bench.cells`
   measures what a cell costs, phase by phase).

Records are named by `icil_paper.records` (`train_record`, `eval_record`,
`features_record`; their keys are the content keys of the specs), written by
`train.train_run`, `eval.evaluate_run_many` and `eval.measure_features`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from icil_paper.config import DATA_ENV_VAR, Preset, get_preset
from icil_paper.config_data import from_dict, to_dict
from icil_paper.data import ensure_many
from icil_paper.data.generate import data_root, demo_path
from icil_paper.eval import evaluate_run_many, measure_features
from icil_paper.records import eval_record, features_record, train_record
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore, results_root
from icil_paper.runspec import EvalSpec, FeatureSpec, RunSpec, eval_key, feature_key, tasks_tag
from icil_paper.seeding import seed_everything
from icil_paper.tables.grid import Cell, run_grid
from icil_paper.tables.spec import TableSpec
from icil_paper.train.rundir import RUNS_ENV_VAR, run_dir_for, runs_root
from icil_paper.train.stored import load_trained, train_run


@dataclass
class RunPlan:
    """One trained policy and everything the chosen tables measure on it."""

    run: RunSpec
    evals: dict[str, EvalSpec] = field(default_factory=dict)
    """eval key -> EvalSpec."""
    features: dict[str, FeatureSpec] = field(default_factory=dict)
    """feature key -> FeatureSpec."""


def plan(tables: Sequence[TableSpec]) -> list[RunPlan]:
    """The units of `tables` grouped by run, in first-seen order."""
    plans: dict[str, RunPlan] = {}
    for table in tables:
        for unit in table.units():
            p = plans.setdefault(unit.run.key(), RunPlan(unit.run))
            if unit.eval is not None:
                p.evals.setdefault(eval_key(unit.run, unit.eval), unit.eval)
            if unit.features is not None:
                p.features.setdefault(feature_key(unit.run, unit.features), unit.features)
    return list(plans.values())


# --------------------------------------------------------------------------- records
def plan_done(store: ResultsStore, p: RunPlan) -> bool:
    """True when every record of the plan is in the store (its training included)."""
    if store.get(*train_record(p.run)) is None:
        return False
    return (all(store.get(*eval_record(p.run, ev)) is not None for ev in p.evals.values())
            and all(store.get(*features_record(p.run, f)) is not None
                    for f in p.features.values()))


# --------------------------------------------------------------------------- data first
def data_needs(plans: Sequence[RunPlan]) -> dict[tuple, int]:
    """(task, source, obs, seed) -> demonstrations needed, over every plan."""
    need: dict[tuple, int] = {}

    def want(task: str, source: str, obs: str, seed: int, n: int) -> None:
        key = (task, source, obs, seed)
        need[key] = max(need.get(key, 0), n)

    for p in plans:
        d = p.run.data
        if d.dataset is None:
            for task in d.tasks:
                want(task, d.source, d.obs, d.seed, d.demos_for(task))
        if p.run.policy.type == "icrt":  # prompt pools
            for ev in p.evals.values():
                task = ev.prompt_task or ev.task
                want(task, ev.prompt_source, d.obs, d.seed, d.demos_for(task))
        for f in p.features.values():
            for task in f.data.tasks:
                want(task, f.data.source, f.data.obs, f.data.seed, f.start + f.data.demos_per_task)
    return need


def ensure_data(preset: Preset, plans: Sequence[RunPlan], progress: bool = True) -> None:
    """Generate every data set the plans read (one worker pool per observation kind)."""
    groups: dict[tuple, dict[tuple[str, str], int]] = {}
    for (task, source, obs, seed), n in data_needs(plans).items():
        groups.setdefault((obs, seed, n), {})[task, source] = n
    for (obs, seed, n), pairs in groups.items():
        tasks = sorted({t for t, _ in pairs})
        sources = sorted({s for _, s in pairs})
        ensure_many(preset, tasks, sources, n=n, seed=seed, obs=obs, progress=progress,
                    workers=preset.data.workers)


# --------------------------------------------------------------------------- one cell
def run_cell(preset: str, run: dict, evals: list[dict], features: list[dict],
             progress: bool = False, data_root: str | None = None) -> dict[str, Any]:
    """Train one run (or find it trained), evaluate it and measure its features.

    Arguments are JSON (what a grid worker receives); every result is written to the
    results store of `preset` as it finishes. `data_root` is the driver's data folder
    (`DataConfig.root`; None: the named preset's): the cell reads the data sets the driver
    generated wherever the driver's spec put them (`--set data.root`), not where the
    environment would. Returns a short summary.
    """
    store = ResultsStore(preset)
    preset = get_preset(preset)
    if data_root is not None:
        preset = preset.replace(data={"root": data_root})
    run_spec = RunSpec.from_dict(run)
    seed_everything(run_spec.seed)
    trained = train_run(run_spec, preset, store, progress=progress)
    policy = None

    def get_policy():
        nonlocal policy
        if policy is None:
            policy = load_trained(run_spec, preset, store, progress=progress)
        return policy

    # every task of the cell side by side: one batched policy forward per step; the envs
    # stay in this (grid worker) process for its next cell, which then builds none
    records = evaluate_run_many(run_spec, [from_dict(EvalSpec, e) for e in evals], get_policy,
                                store, preset, workers=1, progress=progress, keep_envs=True)
    successes = [r["metrics"]["success_rate"] for r in records]
    for f_dict in features:
        spec = from_dict(FeatureSpec, f_dict)
        store.run(*features_record(run_spec, spec),
                  lambda spec=spec: measure_features(get_policy(), spec, preset),
                  seed=run_spec.seed)
    return {"run": run_spec.key(), "label": run_spec.label,
            "steps": trained["metrics"]["steps"], "evals": len(evals),
            "mean_success": float(np.mean(successes)) if successes else None}


# --------------------------------------------------------------------------- many tables
def run_specs(preset: Preset, specs: Sequence[TableSpec], executor: str = "local",
              workers: int | None = None, ray_address: str | None = None,
              gpus_per_cell: float = 0.0, progress: bool = True) -> dict[str, Any]:
    """Compute every missing record of `specs` as grid cells: each cell asks for one CPU
    and `gpus_per_cell` GPUs (Ray schedules by them). Returns the grid's summaries by run
    key."""
    store = ResultsStore(preset.name)
    todo = [p for p in plan(specs) if not plan_done(store, p)]
    if not todo:
        return {}
    # seed-major (every row's first seed, then every row's second, ...): a run stopped
    # part-way leaves every row with about the same number of seeds
    todo.sort(key=lambda p: p.run.seed)
    ensure_data(preset, todo, progress=progress)
    folders = cell_folders(preset)
    # a Ray cell reads the copies in its node's private data folder (cell_folders), not the
    # driver's path
    ray = executor == "ray"
    cells = [plan_cell(preset, p, cell_label(p.run), gpus=gpus_per_cell,
                       data_root=None if ray else preset.data.root,
                       inputs=plan_inputs(preset, p, store) if ray else None)
             for p in todo]
    by_key = {p.run.key(): p for p in todo}
    return run_grid(cells, executor=executor, workers=workers or preset.eval.workers,
                    ray_address=ray_address, progress=progress, folders=folders,
                    done=lambda c: plan_done(store, by_key[c.key]))


def plan_cell(preset: Preset, p: RunPlan, label: str, data_root: str | None = None,
              gpus: float = 0.0, inputs: dict[str, tuple[str, ...]] | None = None) -> Cell:
    """The grid cell that computes plan `p`: `run_cell` on its run, evaluations and
    features (`data_root`: the driver's data folder, None for the named preset's)."""
    return Cell(key=p.run.key(), target="icil_paper.tables.execute:run_cell",
                kwargs={"preset": preset.name, "data_root": data_root, "run": p.run.to_dict(),
                        "evals": [to_dict(e) for e in p.evals.values()],
                        "features": [to_dict(f) for f in p.features.values()]},
                gpus=gpus, label=label, inputs=inputs or {})


def cell_folders(preset: Preset) -> dict[str, str]:
    """{environment variable: folder} of every folder a cell reads or writes: the results
    store, the run folders and the data sets (a Ray node gets private copies of them:
    `tables.grid`, "Cells that share no files with the driver")."""
    return {RESULTS_ENV_VAR: str(results_root()), RUNS_ENV_VAR: str(runs_root()),
            DATA_ENV_VAR: str(data_root(preset))}


def plan_inputs(preset: Preset, p: RunPlan, store: ResultsStore) -> dict[str, tuple[str, ...]]:
    """The files of `cell_folders` a plan's cell reads, relative to their folders: its data
    sets, its records and its run folder (those that exist are sent; the rest it makes)."""
    data, runs = data_root(preset), runs_root()
    demos = {demo_path(preset, task, source, obs).relative_to(data).as_posix()
             for task, source, obs, _ in data_needs([p])}
    ids = [train_record(p.run), *(eval_record(p.run, ev) for ev in p.evals.values()),
           *(features_record(p.run, f) for f in p.features.values())]
    records = [store.record_path(*i).relative_to(store.root).as_posix() for i in ids]
    folder = run_dir_for(p.run, preset.name)
    run_files = sorted(f.relative_to(runs).as_posix() for f in folder.glob("*")
                       if f.is_file() and not f.name.startswith(".")) if folder.is_dir() else []
    return {DATA_ENV_VAR: tuple(sorted(demos)), RESULTS_ENV_VAR: tuple(records),
            RUNS_ENV_VAR: tuple(run_files)}


def cell_label(run: RunSpec) -> str:

    return f"{run.label} {tasks_tag(run.data.tasks)} seed{run.seed}"
