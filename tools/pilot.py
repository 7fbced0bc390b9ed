"""The pilot that sets the reference preset's task scale: is each family and task informative?

    python -m tools.pilot                      # every setting, 2 cells at a time (`make pilot`)
    python -m tools.pilot --settings kitchen_30
    python -m tools.pilot regime [--maniskill] # the regime pilot (`make pilot PILOT_ARGS=regime`)
    python -m tools.pilot episodes             # episodes per task from the committed records

A row whose success is 0 or 1 on a family for every row of a table cannot tell the rows
apart there: averaging it in only dilutes the differences. The reference preset's task
settings (demonstrations per task, training steps; the experts are scripted, so more
demonstrations cost only their generation) were chosen from this pilot: one training seed
of the rows that bound each table's range (Table I's ICRT + LipVQ-VAE and BC-Transformer on
the kitchen suite; Table II's ACT on each ManiSkill task) at each setting of `SETTINGS`,
on the reference preset otherwise, evaluated as the tables evaluate them.

Each setting's cells run through the tables' own `run_cell` on a results folder of their
own (`results/pilot/`, not committed; a rerun skips what is stored), and the summary, each
row's success per task and per family, goes to `results/bench/pilot.json`, which the
chapters quote. One seed: these numbers place a family between 0 and 1, they do not rank
the rows.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
from pathlib import Path
from typing import Any

from icil_paper.config import get_preset, matching_c_lr_scale, task_demo_counts
from icil_paper.config_data import canonical_json
from icil_paper.paper import table_spec
from icil_paper.paper.table_ii import maniskill_settings, maniskill_tokenizer
from icil_paper.planning.design import episode_design
from icil_paper.planning.pilot import REGIME_MIN_FAMILIES, REGIME_RANGE, informative
from icil_paper.planning.staged import as_run
from icil_paper.records import eval_record, features_record
from icil_paper.registry import check_name
from icil_paper.results import ResultsStore, results_root, save_benchmark
from icil_paper.runspec import eval_key, feature_key, run_spec
from icil_paper.tables.cells import (
    RunPlan,
    cell_job,
    cell_label,
    ensure_data,
    plan,
    plan_done,
    run_cell,
    run_jobs,
)
from icil_paper.tables.definitions import evaluation, families, feature_spec

SETTINGS: dict[str, tuple[str, tuple[str, ...]]] = {
    "kitchen_10": ("I", ("data.demos_per_task=10",)),
    "kitchen_30": ("I", ("data.demos_per_task=30",)),
    "kitchen_10_1500": ("I", ("data.demos_per_task=10", "train.steps=1500")),
    "kitchen_10_2000": ("I", ("data.demos_per_task=10", "train.steps=2000")),
    "maniskill_40": ("II", ("tables.maniskill_demos_per_task=40",)),
    "maniskill_100": ("II", ("tables.maniskill_demos_per_task=100",)),
    "maniskill_40_5000": ("II", ("tables.maniskill_demos_per_task=40",
                                 "tables.maniskill_steps=5000")),
}
"""Setting -> (the table whose cells it runs, preset overrides on the reference preset)."""

ROWS = {"I": (("icrt", "lipvq"), ("bc_transformer", None)), "II": (("act", None),)}
"""The rows the pilot trains, per table: (policy, tokenizer)."""

PILOT_FOLDER = "pilot"
"""Under the results and runs roots: the pilot's own records and checkpoints."""


def setting_preset(name: str) -> Any:
    """The reference preset with the setting's overrides."""
    _, overrides = SETTINGS[check_name("pilot setting", name, SETTINGS)]
    return get_preset("reference").with_overrides(list(overrides))


def setting_plans(name: str) -> list[Any]:
    """The tables' RunPlans of the setting's rows (the first training seed only), their
    evaluations without the features."""
    preset = setting_preset(name)
    table, _ = SETTINGS[name]
    wanted = set(ROWS[table])
    out = []
    for p in plan([table_spec(preset, table)]):
        tok = p.run.tokenizer.type if p.run.tokenizer is not None else None
        if (p.run.policy.type, tok) in wanted and p.run.seed == preset.seed:
            out.append(RunPlan(p.run, p.evals))  # success only: no features
    return out


def _summary(name: str, store: Any) -> list[dict[str, Any]]:
    """Each row's success per task and per family from the stored records (None: not run)."""
    rows = []
    for p in setting_plans(name):
        per_task = {}
        for ev in p.evals.values():
            record = store.get(*eval_record(p.run, ev))
            per_task[ev.task] = None if record is None else record["metrics"]["success_rate"]
        fam = {}
        if p.run.data.tasks[0].startswith("kitchen/"):
            for column, tasks in families(list(per_task)).items():
                values = [per_task[t] for t in tasks]
                fam[column] = (None if not values or None in values
                               else round(sum(values) / len(values), 4))
        rows.append({"row": p.run.label, "tasks": per_task, "families": fam,
                     "demos_per_task": p.run.data.demos_per_task,
                     "train_steps": p.run.train.steps,
                     "episodes_per_task": next(iter(p.evals.values())).episodes})
    return rows




def setting_cells(name: str, progress: bool = True) -> list[Any]:
    """The grid cells of the setting's plans not yet stored (their data generated first)."""
    preset = setting_preset(name)
    store = ResultsStore(preset.name)
    todo = [p for p in setting_plans(name) if not plan_done(store, p)]
    if todo:
        ensure_data(preset, todo, progress=progress)
    return [cell_job(preset, p, store, f"{name}: {cell_label(p.run)}") for p in todo]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.pilot", description=__doc__.split("\n\n")[0])
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)

    root = results_root()
    os.environ["ICIL_RESULTS"] = str(root / PILOT_FOLDER)
    os.environ.setdefault("ICIL_RUNS", str(Path("runs") / PILOT_FOLDER))

    cells = {c.key: c for name in args.settings for c in setting_cells(name)}
    cells = sorted(cells.values(), key=lambda c: "icrt" not in c.label)  # longest first
    run_jobs(run_cell, cells, workers=args.workers)
    store = ResultsStore("reference")
    out = Path(args.out or root / "bench" / "pilot.json")
    # settings not rerun keep their stored summary (a pilot is run a setting at a time)
    record = {"settings": json.loads(out.read_text())["settings"] if out.exists() else {}}
    for name in args.settings:
        summary = _summary(name, store)
        record["settings"][name] = {"table": SETTINGS[name][0],
                                    "overrides": list(SETTINGS[name][1]),
                                    "rows": summary, "informative": informative(summary)}
        print(f"== {name}: {record['settings'][name]}", flush=True)
    save_benchmark("pilot", record, out)


# --------------------------------------------------------------------------- the regime
REGIME_ROWS = (("icrt", "lipvq"), ("icrt", "mlp"), ("icrt", "vq"), ("bc_transformer", None))
"""The RoboCasa-table rows the regime pilot trains: the first at every budget (its learning
curve and level alone set the regime), the others at the budget it chose, reported beside it;
their per-episode outcomes are kept so that the reference run's seeds and episodes can be
planned from paired variances."""
DATA_CURVE_ROW = ("bc_transformer", None)
"""The row of the data curve: the policy that is not in-context, which more demonstrations
help most; the count is chosen where more no longer raises its success beyond noise."""
DATA_COUNTS = (10, 25, 50)
"""Demonstrations per task of the data curve (at least three)."""
REGIME_MANISKILL_ROWS = (("act", "lipvq"),)
"""The ManiSkill rows of the regime pilot (one policy per task, as Table II)."""
REGIME_SEED = 20
"""The regime pilot's first seed index: its training seeds, demonstration sets
(`seeding.data_set_seed`) and scene sets are preset.seed + 20, 21, ...; the reference run's
are preset.seed + 0 .. 14, and the committed pilot ran at base 0, not the reference run's
`config.REFERENCE_SEED`, so choosing the regime cannot select for a result the run reports."""
REGIME_BUDGETS = (500, 1000, 2000)
"""Training steps of the regime pilot's learning curve (at least three)."""
REGIME_EPISODES = 10
"""Rollouts per task of every pilot evaluation (fixed here, so that the pilot's records do not
depend on the reference preset's episodes, which are planned from them)."""


def regime_preset(demos_per_task: int, steps: int, overrides: tuple[str, ...] = (),
                  task_demos: tuple[str, ...] = ()) -> Any:
    """The reference preset at a pilot setting (demonstrations per task, the exceptions
    `task_demos` as `TASK:N`, training steps), its Lipschitz bounds' learning-rate multiple
    matched to those steps as the presets match theirs (`config.matching_c_lr_scale`)."""
    preset = get_preset("reference").with_overrides(
        [f"data.demos_per_task={demos_per_task}", f"train.steps={steps}",
         f"eval.episodes_per_task={REGIME_EPISODES}", *overrides])
    preset = preset.replace(data={"task_demos": tuple(task_demos)})
    scale = round(matching_c_lr_scale(preset.train), 3)
    changes = {}
    for field in ("lip_mlp", "lipvq", "lipfsq", "liprvq"):
        tok = getattr(preset.tokenizers, field)
        changes[field] = dataclasses.replace(tok, lipschitz=dataclasses.replace(
            tok.lipschitz, c_lr_scale=scale))
    return preset.replace(tokenizers=preset.tokenizers.replace(**changes))


def regime_plans(preset: Any, seeds: int, maniskill: bool = False,
                 rows: tuple[tuple[str, str | None], ...] = REGIME_ROWS) -> list[Any]:
    """RunPlans of the regime pilot at one setting: every row of `REGIME_ROWS` (and, with
    `maniskill`, `REGIME_MANISKILL_ROWS` on each ManiSkill task) at seed indices REGIME_SEED
    .. REGIME_SEED + seeds - 1, each evaluated on every task on its own scene set, and the
    Lipschitz rows' tokenizer features (their capped share of rows)."""
    out = []
    for k in range(REGIME_SEED, REGIME_SEED + seeds):
        for policy, tokenizer in rows:
            run = run_spec(preset, policy, tokenizer, seed=preset.seed + k)
            evals = [evaluation(preset, run, task, k) for task in preset.data.robocasa_tasks]
            features = ([feature_spec(preset, run)] if tokenizer and "lip" in tokenizer else [])
            out.append(RunPlan(run, {eval_key(run, e): e for e in evals},
                               {feature_key(run, f): f for f in features}))
        if not maniskill:
            continue
        demos, steps, episodes = maniskill_settings(preset)
        evaluated = preset.replace(eval={"episodes_per_task": episodes})
        for policy, tokenizer in REGIME_MANISKILL_ROWS:
            for task in preset.data.maniskill_tasks:
                run = run_spec(preset, policy, tokenizer, tasks=[task], seed=preset.seed + k)
                train = dataclasses.replace(run.train, steps=steps)
                run = run.replace(data=dataclasses.replace(run.data, demos_per_task=demos),
                                  train=train, tokenizer=maniskill_tokenizer(run, train))
                ev = evaluation(evaluated, run, task, k)
                out.append(RunPlan(run, {eval_key(run, ev): ev}))
    return out


def _per_seed(store: Any, plans: list[Any]) -> dict[str, list[dict[str, Any]]]:
    """{row label: [per seed: {"tasks": {task: success}, "capped": share or None}]} from the
    stored records (None where a record is missing)."""
    rows: dict[str, list[dict[str, Any]]] = {}
    for p in plans:
        tasks = {}
        for ev in p.evals.values():
            record = store.get(*eval_record(p.run, ev))
            tasks[ev.task] = None if record is None else record["metrics"]["success_rate"]
        capped = None
        for f in p.features.values():
            record = store.get(*features_record(p.run, f))
            if record is None:  # measured on other held-out trajectories: the share of
                record = _any_features(store, p.run, f)  # capped rows is the weights' alone
            if record is not None:
                capped = record["metrics"].get("capped_fraction")
        suite = p.run.data.tasks[0].split("/", 1)[0]
        rows.setdefault(f"{suite}:{p.run.label}", []).append(
            {"seed": p.run.seed, "tasks": tasks, "capped": capped,
             "episodes": _episodes(store, p)})
    return rows


def _episodes(store: Any, plan: Any) -> dict[str, list[bool]] | None:
    """{task: per-episode successes} of a plan's stored evaluations (None: one is missing)."""
    out = {}
    for ev in plan.evals.values():
        record = store.get(*eval_record(plan.run, ev))
        if record is None:
            return None
        out[ev.task] = [bool(e["success"]) for e in record["metrics"]["per_episode"]]
    return out


def _any_features(store: Any, run: Any, spec: Any) -> dict[str, Any] | None:
    """A features record of `run` whatever held-out trajectories it scored (None: none)."""
    kind, name, config = features_record(run, spec)
    wanted = canonical_json(config["run"])
    for record in store.records(kind):
        if (record.get("name") == name
                and canonical_json(record.get("config", {}).get("run")) == wanted):
            return record
    return None


def _mean(values: list[float | None]) -> float | None:
    values = [v for v in values if v is not None]
    return round(float(sum(values) / len(values)), 4) if values else None


def plateau(curve: dict[int, list[float]], episodes: int) -> int | None:
    """The first budget of a learning curve ({steps: per-seed averages}) after which the next
    budget gains nothing beyond noise: its mean gain is within two standard errors (from the
    per-seed spread with two seeds or more, else the episodes' binomial noise of `episodes`
    rollouts in all). None when every budget still gains."""
    budgets = sorted(curve)
    for a, b in zip(budgets, budgets[1:], strict=False):
        x, y = curve[a], curve[b]
        if not x or not y:
            return None
        mx, my = sum(x) / len(x), sum(y) / len(y)
        if len(x) > 1 and len(y) > 1:
            vx = sum((v - mx) ** 2 for v in x) / (len(x) - 1)
            vy = sum((v - my) ** 2 for v in y) / (len(y) - 1)
            se = math.sqrt(vx / len(x) + vy / len(y))
        else:
            p = min(max((mx + my) / 2, 0.05), 0.95)
            se = math.sqrt(2 * p * (1 - p) / max(1, episodes))
        if my - mx <= 2 * se:
            return a
    return None


def data_curve_record(counts: tuple[int, ...], steps: int, seeds: int) -> dict[str, Any]:
    """The data curve: `DATA_CURVE_ROW`'s success (mean over tasks, per seed) at each count of
    demonstrations per task, trained `steps` steps; `saturated` says whether the largest count
    gains nothing beyond noise over the one before (`plateau` on the last two counts), so that
    the regime trains every row where more demonstrations no longer help."""
    store = ResultsStore("reference")
    policy, tokenizer = DATA_CURVE_ROW
    curve: dict[int, list[float]] = {}
    episodes = 0
    for n in counts:
        preset = regime_preset(n, steps)
        episodes = preset.eval.episodes_per_task * len(preset.data.robocasa_tasks) * seeds
        rows = _per_seed(store, regime_plans(preset, seeds, rows=(DATA_CURVE_ROW,)))
        per_seed = next(iter(rows.values()), [])
        curve[n] = [_mean(list(s["tasks"].values())) for s in per_seed
                    if None not in s["tasks"].values()]
    done = {n: v for n, v in curve.items() if len(v) == seeds}
    last = sorted(done)[-2:]
    saturated = (len(done) == len(counts) and len(last) == 2
                 and plateau({n: done[n] for n in last}, episodes) == last[0])
    return {"row": f"{policy}+{tokenizer}" if tokenizer else policy, "train_steps": steps,
            "counts": list(counts), "seeds": seeds,
            "curve": {str(n): _mean(v) for n, v in curve.items()},
            "per_seed": {str(n): v for n, v in curve.items()},
            "saturated": saturated,
            "chosen": max(counts) if saturated else None}


def regime_record(demos_per_task: int, budgets: tuple[int, ...], seeds: int,
                  maniskill: bool = False, task_demos: tuple[str, ...] = (),
                  data_counts: tuple[int, ...] = (), data_seeds: int = 0) -> dict[str, Any]:
    """The regime pilot's record (`results/bench/regime.json`'s schema) from the stored
    records: the data curve (`data_curve_record`, when `data_counts` are given), the learning
    curve of every row, the plateau of ICRT + LipVQ-VAE (`plateau`), the budget chosen (the
    plateau, or the last budget when none is reached, unless fewer than
    `REGIME_MIN_FAMILIES` of its families lie within `REGIME_RANGE` there: then the largest
    budget below that keeps them in range), and at that budget each row's success per
    family (ManiSkill: per task), its per-episode outcomes per seed and its capped share of
    encoder rows per seed. Difficulty is read from ICRT + LipVQ-VAE's level alone."""
    store = ResultsStore("reference")
    preset = regime_preset(demos_per_task, budgets[-1], task_demos=task_demos)
    suite = preset.data.robocasa_tasks[0].split("/", 1)[0]
    curve: dict[str, dict[int, list[float]]] = {}
    by_budget = {}
    for steps in budgets:
        at_steps = regime_preset(demos_per_task, steps, task_demos=task_demos)
        rows = _per_seed(store, regime_plans(at_steps, seeds, maniskill))
        by_budget[steps] = rows
        for label, per_seed in rows.items():
            if label.startswith(f"{suite}:"):
                averages = [_mean(list(s["tasks"].values())) for s in per_seed
                            if None not in s["tasks"].values()]
                curve.setdefault(label.split(":", 1)[1], {})[steps] = averages
    episodes = preset.eval.episodes_per_task * len(preset.data.robocasa_tasks)
    lip = curve.get("icrt+lipvq", {})
    chosen = plateau({b: v for b, v in lip.items() if v}, episodes * seeds)
    last = chosen if chosen is not None else max((b for b, v in lip.items() if v), default=None)
    in_range = {b: _families_in_range(by_budget[b].get(f"{suite}:icrt+lipvq", []),
                                      preset.data.robocasa_tasks)
                for b in budgets if lip.get(b)}
    at, because = choose_budget(chosen, last, in_range)
    record: dict[str, Any] = {
        "suite": suite, "tasks": list(preset.data.robocasa_tasks),
        "train_steps": at, "chosen_because": because, "plateau_steps": chosen,
        "families_in_range": {str(b): n for b, n in in_range.items()},
        "plateau_reached": chosen is not None,
        "demos_per_task": demos_per_task, "task_demos": task_demo_counts(task_demos),
        "seeds": seeds,
        "seed_indices": list(range(REGIME_SEED, REGIME_SEED + seeds)),
        "episodes_per_task": preset.eval.episodes_per_task,
        "budgets": list(budgets), "budgets_done": sorted(b for b, v in lip.items() if v),
        "families": {}, "maniskill": {}, "outcomes": {},
        "learning_curve": {row: {str(b): _mean(v) for b, v in sorted(c.items())}
                           for row, c in curve.items()},
        "capped_share": {}}
    if data_counts:
        record["data_curve"] = data_curve_record(tuple(data_counts), budgets[-1],
                                                 data_seeds or seeds)
    for label, per_seed in (by_budget.get(at, {}) if at is not None else {}).items():
        row_suite, row = label.split(":", 1)
        if row_suite == suite:
            fam = {}
            for column, tasks in families(list(preset.data.robocasa_tasks)).items():
                if tasks:
                    fam[column] = _mean([_mean([s["tasks"].get(t) for t in tasks])
                                         for s in per_seed])
            record["families"][row] = fam
            record["outcomes"][row] = {str(s["seed"]): s["episodes"] for s in per_seed}
            shares = [s["capped"] for s in per_seed]
            if any(v is not None for v in shares):
                record["capped_share"][row] = shares
        else:
            for s in per_seed:
                for task, value in s["tasks"].items():
                    record["maniskill"].setdefault(row, {}).setdefault(
                        task.split("/", 1)[1], []).append(value)
    for row, tasks in record["maniskill"].items():
        record["maniskill"][row] = {t: _mean(v) for t, v in tasks.items()}
    low, high = REGIME_RANGE
    fam = record["families"].get("icrt+lipvq", {})
    record["within_range"] = {f: (v is not None and low <= v <= high) for f, v in fam.items()}
    return record


def choose_budget(plateau_steps: int | None, last: int | None,
                  in_range: dict[int, int]) -> tuple[int | None, str]:
    """(budget, why) from ICRT + LipVQ-VAE's learning curve: its plateau (else the last
    budget run), unless fewer than `REGIME_MIN_FAMILIES` of its families lie within
    `REGIME_RANGE` there ({budget: families in range}); then the largest budget below it
    where at least that many do, if any."""
    at = plateau_steps if plateau_steps is not None else last
    because = "plateau" if plateau_steps is not None else "last budget"
    if at is not None and in_range.get(at, 0) < REGIME_MIN_FAMILIES:
        below = [b for b, n in in_range.items() if b <= at and n >= REGIME_MIN_FAMILIES]
        if below:  # the plateau's families sit at 0 or 1: the most steps that keep them apart
            return max(below), f"in range below the {because}"
    return at, because


def _families_in_range(per_seed: list[dict[str, Any]], tasks: tuple[str, ...]) -> int:
    """How many families of one row's per-seed successes lie within `REGIME_RANGE`."""
    low, high = REGIME_RANGE
    values = [_mean([_mean([s["tasks"].get(t) for t in group]) for s in per_seed])
              for group in families(list(tasks)).values() if group]
    return sum(v is not None and low <= v <= high for v in values)


def _regime_cells(preset: Any, plans: list[Any], label: str) -> list[Any]:
    """The grid cells of the plans not yet stored (their data generated first)."""
    store = ResultsStore("reference")
    todo = [p for p in plans if not plan_done(store, p)]
    if todo:
        ensure_data(preset, todo, progress=False)
    return [cell_job(preset, p, store, f"{label}: {cell_label(p.run)}") for p in todo]


def _run_cells(cells: list[Any], workers: int) -> None:
    """Train and evaluate the cells, each once (two settings can share one), longest first."""
    unique = {c.key: c for c in cells}
    if unique:
        run_jobs(run_cell, sorted(unique.values(), key=lambda c: "icrt" not in c.label),
                 workers=workers)


def regime_main(argv: list[str] | None = None) -> None:
    """`python -m tools.pilot regime`: the data curve (`DATA_CURVE_ROW` at each
    count of `--data-counts`, trained the largest budget) and ICRT + LipVQ-VAE's learning
    curve at every budget (at `--demos`, default the largest count), then the rows reported
    beside it (`REGIME_ROWS`, and with `--maniskill` ACT + LipVQ-VAE on each ManiSkill task)
    at the budget the curve chose (`regime_record`); writes `results/bench/regime.json`.
    Resumable: every finished record is kept under `results/pilot/`."""
    parser = argparse.ArgumentParser(prog="python -m tools.pilot regime", description=regime_main.__doc__)
    parser.add_argument("--demos", type=int, default=None,
                        help="demonstrations per task (default: the largest data count)")
    parser.add_argument("--task-demos", nargs="*", default=[], metavar="TASK:N",
                        help="tasks trained on other numbers of demonstrations "
                             "(metaworld/pick-place:50)")
    parser.add_argument("--data-counts", type=int, nargs="*", default=list(DATA_COUNTS))
    parser.add_argument("--data-seeds", type=int, default=2)
    parser.add_argument("--budgets", type=int, nargs="+", default=list(REGIME_BUDGETS))
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--maniskill", action="store_true")
    parser.add_argument("--no-beside", action="store_true",
                        help="train ICRT + LipVQ-VAE's learning curve only")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--summary-only", action="store_true",
                        help="write regime.json from the stored records without training")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    counts = tuple(sorted(set(args.data_counts)))
    if counts and len(counts) < 3:
        parser.error("give at least three --data-counts (or none)")
    demos = args.demos or (max(counts) if counts else None)
    if (len(args.budgets) < 3 or min(args.budgets) < 1 or args.seeds < 1 or not demos
            or demos < 1 or args.data_seeds < 1):
        parser.error("give at least three positive budgets, and positive --seeds, "
                     "--data-seeds and --demos")
    try:
        task_demos = tuple(f"{t}:{n}" for t, n in task_demo_counts(args.task_demos).items())
    except ValueError as exc:
        parser.error(str(exc))

    root = results_root()
    os.environ["ICIL_RESULTS"] = str(root / PILOT_FOLDER)
    os.environ.setdefault("ICIL_RUNS", str(Path("runs") / PILOT_FOLDER))
    budgets = tuple(sorted(set(args.budgets)))
    curve_row = REGIME_ROWS[0]
    beside = tuple(r for r in REGIME_ROWS[1:])
    if not args.summary_only:
        cells = []
        for n in counts:  # the data curve, at the largest budget
            preset = regime_preset(n, budgets[-1])
            cells += _regime_cells(preset, regime_plans(preset, args.data_seeds,
                                                        rows=(DATA_CURVE_ROW,)), f"data {n}")
        for steps in budgets:  # the learning curve
            preset = regime_preset(demos, steps, task_demos=task_demos)
            cells += _regime_cells(preset, regime_plans(preset, args.seeds, rows=(curve_row,)),
                                   f"regime {steps}")
        _run_cells(cells, args.workers)
        chosen = regime_record(demos, budgets, args.seeds,
                               task_demos=task_demos)["train_steps"]
        if not args.no_beside and chosen is not None:
            preset = regime_preset(demos, chosen, task_demos=task_demos)
            _run_cells(_regime_cells(preset, regime_plans(preset, args.seeds, args.maniskill,
                                                          rows=beside), f"regime {chosen}"),
                       args.workers)
    record = regime_record(demos, budgets, args.seeds, args.maniskill, task_demos,
                           data_counts=counts, data_seeds=args.data_seeds)
    print(json.dumps({k: record.get(k) for k in ("train_steps", "learning_curve", "families",
                                                 "data_curve", "within_range")}), flush=True)
    save_benchmark("regime", record, args.out or root / "bench" / "regime.json")


def episodes_main(argv: list[str] | None = None) -> None:
    """`python -m tools.pilot episodes`: the cost-optimal episodes per task of every suite
    whose rows the committed reference records hold (`planning.design.episode_design`:
    each suite's paired variance split into its episode and seed-by-row parts), written to
    `results/bench/episodes.json`, which the reference preset's episode counts are read
    from (`planning.pilot.recorded_episodes`). The records are found by the keys of the
    code that made them: run it at the commit its record names."""
    parser = argparse.ArgumentParser(prog="python -m tools.pilot episodes",
                                     description=episodes_main.__doc__)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    store = ResultsStore("reference")
    rows = episode_design(as_run(get_preset("reference"), store), store)
    if not rows:
        sys.exit("tools.pilot episodes: no suite's rows are in results/reference under the "
                 "current keys; run it at the commit that made the records")
    save_benchmark("episodes", {"rows": rows}, args.out)


if __name__ == "__main__":
    if sys.argv[1:2] == ["regime"]:
        regime_main(sys.argv[2:])
    elif sys.argv[1:2] == ["episodes"]:
        episodes_main(sys.argv[2:])
    else:
        main()
