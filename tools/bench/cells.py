"""What one seed of each kind of cell costs, phase by phase, against its compute floor.

    python -m tools.bench.cells                     # a tenth of each reference cell
    python -m tools.bench.cells --full              # the reference preset's own cells
    python -m tools.bench.cells --kinds act_maniskill --scale 0.05

A kind of cell (`KINDS`: Table I's ICRT + LipVQ-VAE and BC-Transformer on the Meta-World
tasks, Table II's ACT on ManiSkill's first task, Table V's ICRT + LipVQ-VAE trained on the
Panda door and drawer tasks and evaluated on the Kinova ones) is one
seed of a reference-preset cell from the tables' own plan (`tables.cells.plan`), run as the
pool runs it (`tables.cells.run_cell`) in a fresh process, against empty results and runs
folders (the data sets are generated first, untimed). Each process runs two seeds one after
the other, as a pool worker does: `first` pays the process start and builds the
environments, `steady` is what each later cell costs. A cell's wall time is split into the
phases the library marks (`icil_paper.timing`) and compared with its compute floor: its
training steps at the measured time of a step, the policy's forward passes in its rollouts
(`eval.policy`, prompt prefill included), and its environment steps at the raw simulator
rate on the same tasks (`raw_rates`): `floor_ratio = wall / floor`. `floor_ratio_no_policy`
leaves the forward passes out of the floor (the figure before they were counted).
`--scale` shortens every cell (steps, checkpoint interval, episodes) in proportion. Writes
results/bench/cells.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from icil_paper.config import get_preset
from icil_paper.config_data import to_dict
from icil_paper.eval.outcomes import episode_seed
from icil_paper.fileio import atomic_write_json
from icil_paper.paper import table_spec
from icil_paper.records import eval_record
from icil_paper.results import ResultsStore, save_benchmark
from icil_paper.seeding import cpu_threads
from icil_paper.sim import make_env, make_expert
from icil_paper.tables.cells import RunPlan, ensure_data, plan, run_cell
from icil_paper.timing import recording

KINDS = ("icrt_lipvq", "bc_transformer", "act_maniskill", "kinova_eval")
"""The kinds of cell measured, in the order they run."""

TARGET = 1.25
"""The floor ratio every kind of cell should stay within."""

RAW_STEPS = 150
"""Expert-driven simulator steps per task that measure the raw simulator rate (`raw_rates`)."""


# --------------------------------------------------------------------------- which cell
def kind_cell(preset: Any, kind: str) -> tuple[Any, list[Any]]:
    """(run, evaluations) of one seed of `kind` at `preset`, from the tables' plan."""
    table, policy, tokenizer = {"icrt_lipvq": ("I", "icrt", "lipvq"),
                                "bc_transformer": ("I", "bc_transformer", None),
                                "act_maniskill": ("II", "act", None),
                                "kinova_eval": ("V", "icrt", "lipvq")}[kind]
    for p in plan([table_spec(preset, table)]):
        tok = getattr(p.run.tokenizer, "type", None) if p.run.tokenizer else None
        if p.run.policy.type == policy and tok == tokenizer:
            return p.run, list(p.evals.values())
    raise ValueError(f"table {table} at preset {preset.name!r} has no {kind} cell")


def shortened(run: Any, evals: list[Any], scale: float | None) -> tuple[Any, list[Any]]:
    """The cell at `scale` of its size: training steps and episodes per task times `scale`
    (at least 1 episode; checkpoints as often, relative to the run's length). None keeps
    the preset's."""
    if scale is None:
        return run, evals
    steps = max(1, round(run.train.steps * scale))
    run = run.replace(train=dataclasses.replace(
        run.train, steps=steps, ckpt_every=max(1, round(run.train.ckpt_every * scale)),
        warmup_steps=max(1, round(run.train.warmup_steps * scale))))
    evals = [dataclasses.replace(ev, episodes=max(1, round(ev.episodes * scale)))
             for ev in evals]
    return run, evals


# --------------------------------------------------------------------------- in the child
def raw_rates(evals: list[Any], obs: str, steps: int = RAW_STEPS) -> dict[str, float]:
    """Simulator steps per second on each evaluation's task (its scenes), on one thread,
    driven by the task's scripted expert from the evaluation's first episode seeds (so the
    arm moves and makes contact as a policy's does; zero actions step faster), counting
    `env.step` alone: not environment creation, resets or the expert's own computation."""
    rates = {}
    with cpu_threads(1):
        for ev in evals:
            options = {"scenes": ev.scenes} if ev.scenes != "generated" else {}
            env = make_env(ev.task, obs=obs, seed=ev.seed, **options)
            expert = make_expert(ev.task)
            spent, done, episode = 0.0, 0, 0
            while done < steps:
                obs_, _ = env.reset(seed=episode_seed(ev.seed, episode))
                expert.reset(env, obs_)
                for _ in range(min(env.horizon, steps - done)):
                    action = expert.act(obs_)
                    t = time.perf_counter()
                    obs_, _, terminated, truncated, _ = env.step(action)
                    spent += time.perf_counter() - t
                    done += 1
                    if terminated or truncated:
                        break
                episode += 1
            env.close()
            rates[ev.task] = steps / spent
    return rates


def _cell_cost(preset: Any, run: Any, evals: list[Any], rates: dict[str, float] | None,
               before_s: float = 0.0) -> dict[str, Any]:
    """Run one cell through `run_cell` and split its wall time (plus `before_s`, the
    process start charged to it) by phase; the floor uses `rates` (measured after the
    first cell: `raw_rates`)."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    with recording() as phases:
        run_cell(preset.name, run.to_dict(), [to_dict(e) for e in evals], [])
    wall = time.perf_counter() - wall0 + before_s
    cpu = time.process_time() - cpu0
    store = ResultsStore(preset.name)
    per_task = {ev.task: store.get(*eval_record(run, ev))["metrics"]["per_episode"]
                for ev in evals}
    env_steps = {task: sum(e["steps"] for e in rows) for task, rows in per_task.items()}
    rates = rates or raw_rates(evals, run.data.obs)
    split = {name: v["wall_s"] for name, v in phases.as_dict().items()}
    if before_s:
        split["process_start"] = round(before_s, 3)
    split["other"] = round(wall - sum(split.values()), 3)
    steps = phases.count.get("train.step", 0)
    train_floor = split.get("train.step", 0.0)
    policy_floor = split.get("eval.policy", 0.0)
    sim_floor = sum(n / rates[task] for task, n in env_steps.items())
    floor = train_floor + policy_floor + sim_floor
    return {"seed": run.seed, "run_key": run.key(), "train_steps": steps,
            "episodes": sum(len(rows) for rows in per_task.values()),
            "env_steps": sum(env_steps.values()),
            "wall_s": round(wall, 3), "cpu_s": round(cpu, 3),
            "phases_s": dict(sorted(split.items(), key=lambda kv: -kv[1])),
            "step_ms": round(1000 * train_floor / steps, 3) if steps else None,
            "raw_steps_per_s": {t: round(r, 2) for t, r in rates.items()},
            "floor_s": {"train": round(train_floor, 3), "policy": round(policy_floor, 3),
                        "sim": round(sim_floor, 3), "total": round(floor, 3)},
            "floor_ratio": round(wall / floor, 4) if floor > 0 else None,
            "floor_ratio_no_policy": (round(wall / (floor - policy_floor), 4)
                                      if floor > policy_floor else None)}


def measure(kind: str, preset_name: str, scale: float | None, started: float
            ) -> dict[str, Any]:
    """Run two seeds of `kind` one after the other in this process, as a pool worker runs
    cells (see the module docstring); `started` is the time.time() at which the parent
    launched this process. The first seed pays the process start (interpreter, imports)
    and builds the environments; the second (`steady`) is what every later cell of a
    pool worker costs, and its `floor_ratio` is the kind's."""
    preset = get_preset(preset_name)
    run, evals = shortened(*kind_cell(preset, kind), scale)
    for module in ("icil_paper.eval", "icil_paper.train.stored", "icil_paper.policies",
                   "icil_paper.sim." + {"act_maniskill": "maniskill",
                                        "kinova_eval": "kitchen"}.get(kind, "metaworld")):
        __import__(module)
    process_start = time.time() - started
    first = _cell_cost(preset, run, evals, None, before_s=process_start)
    rates = first["raw_steps_per_s"]
    second = run.replace(seed=run.seed + 1)
    steady = _cell_cost(preset, second, evals, rates)
    return {"kind": kind, "run": run.label, "tasks": [ev.task for ev in evals],
            "first": first, "steady": steady, "floor_ratio": steady["floor_ratio"],
            "floor_ratio_no_policy": steady["floor_ratio_no_policy"],
            "seed_cost_s": steady["wall_s"]}


# --------------------------------------------------------------------------- the parent
def run_kinds(kinds: list[str], preset_name: str, scale: float | None,
              folder: Path) -> list[dict[str, Any]]:
    """Each kind in a fresh process sharing `folder` as its results and runs store."""
    env = {**os.environ, "ICIL_RESULTS": str(folder / "results"),
           "ICIL_RUNS": str(folder / "runs"), "PYTHONUNBUFFERED": "1"}
    out = []
    for kind in kinds:
        result_file = folder / f"{kind}.json"
        cmd = [sys.executable, "-m", "tools.bench.cells", "--child", kind,
               "--preset", preset_name, "--started", repr(time.time()), "--out", str(result_file)]
        cmd += ["--full"] if scale is None else ["--scale", str(scale)]
        print(f"== {kind}", flush=True)
        subprocess.run(cmd, env=env, check=True)
        result = json.loads(result_file.read_text())
        for which in ("first", "steady"):
            r = result[which]
            print(f"   {which}: wall {r['wall_s']:.1f} s, floor {r['floor_s']['total']:.1f} s, "
                  f"ratio {r['floor_ratio']:.3f} ({r['floor_ratio_no_policy']:.3f} without the "
                  f"policy's forward passes): {r['phases_s']}", flush=True)
        out.append(result)
    return out


def ensure_kind_data(preset_name: str, kinds: list[str]) -> None:
    """Generate the data sets the cells read (not timed: a table run does it once)."""
    preset = get_preset(preset_name)
    plans = []
    for kind in kinds:
        run, evals = kind_cell(preset, kind)
        for seed in (run.seed, run.seed + 1):
            plans.append(RunPlan(run.replace(seed=seed),
                                 {str(i): ev for i, ev in enumerate(evals)}))
    ensure_data(preset, plans)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.cells",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    parser.add_argument("--preset", default="reference")
    parser.add_argument("--scale", type=float, default=0.1,
                        help="training steps and episodes per task as a fraction of the "
                             "preset's (default 0.1)")
    parser.add_argument("--full", action="store_true", help="the preset's cells unshortened")
    parser.add_argument("--out", default=None)
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--started", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    scale = None if args.full else args.scale
    if args.child:
        atomic_write_json(Path(args.out), measure(args.child, args.preset, scale, args.started))
        return

    kinds = list(args.kinds)
    ensure_kind_data(args.preset, kinds)
    with tempfile.TemporaryDirectory(prefix="icil-cells-") as tmp:
        cells = run_kinds(kinds, args.preset, scale, Path(tmp))
    record = {"preset": args.preset, "scale": scale, "target_floor_ratio": TARGET,
              "cells": cells,
              "floor_ratio": {c["kind"]: c["floor_ratio"] for c in cells},
              "floor_ratio_no_policy": {c["kind"]: c["floor_ratio_no_policy"] for c in cells},
              "seed_cost_s": {c["kind"]: c["seed_cost_s"] for c in cells}}
    save_benchmark("cells", record, args.out)


if __name__ == "__main__":
    main()
