"""Simulator benchmark: demonstration generation throughput against raw stepping, in one run.

    python -m tools.bench.sim                 # ManiSkill suite + one kitchen task
    python -m tools.bench.sim --demos 3 --raw-steps 300 --tasks maniskill/pick_cube

For each task, in one process and one after the other:

- raw stepping: `--raw-steps` random actions through the project's env (`make_env`, state
  observations), timing `step` alone (resets at the horizon timed apart, `reset_s`); for
  ManiSkill also ManiSkill's own gym env without the project's wrapper
  (`maniskill_gym_steps_per_s`);
- demo generation: `--demos` demos of the `generated` source exactly as `ensure_demos` makes
  them (expert, failed attempts, simulator-state recording, the HDF5 shard write), counting
  the steps of the kept demos.

`ratio = demo_steps_per_s / raw_steps_per_s` (1.0: resets, the expert and the bookkeeping
cost nothing), per process. Writes results/bench/sim.json.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper.data.generate import _close_cache, _Job, generate_one, shard_path
from icil_paper.data.hdf5 import load_demos
from icil_paper.results import save_benchmark
from icil_paper.seeding import seed_everything
from icil_paper.sim import make_env, suite_unavailable, tasks_of
from icil_paper.sim.maniskill.env import (
    MANISKILL_TASKS,
    default_render_backend,
    default_sim_backend,
)


def _raw_steps(env: Any, n: int, seed: int) -> tuple[float, float]:
    """(steps per second of `env.step` alone, mean seconds of one `env.reset`)."""
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    env.reset(seed=seed)
    resets, reset_s, step_s = 1, time.perf_counter() - start, 0.0
    for _ in range(n):
        action = rng.uniform(-1, 1, env.action_dim)
        start = time.perf_counter()
        *_, terminated, truncated, _ = env.step(action)
        step_s += time.perf_counter() - start
        if terminated or truncated:
            start = time.perf_counter()
            env.reset()
            reset_s += time.perf_counter() - start
            resets += 1
    return n / step_s, reset_s / resets


def _maniskill_gym_steps(task: str, n: int, seed: int) -> float:
    import gymnasium as gym
    import mani_skill.envs  # noqa: F401

    env = gym.make(MANISKILL_TASKS[task].env_id, obs_mode="state",
                   control_mode="pd_ee_delta_pose", sim_backend=default_sim_backend(),
                   render_backend=default_render_backend())
    env.reset(seed=seed)
    space = env.action_space
    space.seed(seed)
    start = time.perf_counter()
    for _ in range(n):
        env.step(space.sample())
    rate = n / (time.perf_counter() - start)
    env.close()
    return rate


def bench_task(task: str, demos: int, raw_steps: int, seed: int = 0) -> dict[str, Any]:
    """Raw stepping and demo generation figures of one task."""
    env = make_env(task, obs="state", seed=seed)
    _raw_steps(env, 20, seed)  # warm-up (first-step allocations)
    raw, reset_s = _raw_steps(env, raw_steps, seed)
    env.close()
    row: dict[str, Any] = {"task": task, "raw_steps_per_s": raw, "raw_steps": raw_steps,
                           "reset_s": reset_s}
    if task.startswith("maniskill/"):
        row["maniskill_gym_steps_per_s"] = _maniskill_gym_steps(task, raw_steps, seed)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.hdf5"
        attrs = {"task": task, "source": "generated", "obs_kind": "state", "base_seed": seed}
        jobs = [_Job(task, "generated", "state", i, seed, str(shard_path(path, i)), attrs, {})
                for i in range(demos + 1)]
        generate_one(jobs[0])  # builds the env and the expert (not timed, like the warm-up)
        start = time.perf_counter()
        summaries = [generate_one(job) for job in jobs[1:]]
        seconds = time.perf_counter() - start
        steps = sum(len(load_demos(shard_path(path, i))[0]) for i in range(1, demos + 1))

    _close_cache()
    row.update(demos=demos, demo_steps=steps, demo_seconds=seconds,
               attempts=sum(s["attempts"] for s in summaries),
               demo_steps_per_s=steps / seconds)
    row["ratio"] = row["demo_steps_per_s"] / raw
    return row


def default_tasks() -> list[str]:
    tasks = list(tasks_of("maniskill"))
    kitchen = tasks_of("kitchen")
    if kitchen:
        tasks.append("kitchen/open_drawer" if "kitchen/open_drawer" in kitchen else kitchen[0])
    return tasks


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.sim",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="*", help="tasks (default: ManiSkill + one kitchen)")
    parser.add_argument("--demos", type=int, default=5, help="timed demos per task")
    parser.add_argument("--raw-steps", type=int, default=500, help="timed random steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="output JSON (default results/bench/sim.json)")
    args = parser.parse_args(argv)
    seed_everything(args.seed)
    try:
        import torch

        torch.set_num_threads(1)  # per-process figures, like a generation worker
    except ImportError:
        pass
    tasks = args.tasks or default_tasks()
    rows = []
    start = time.perf_counter()
    for task in tasks:
        row = bench_task(task, args.demos, args.raw_steps, args.seed)
        rows.append(row)
        print(f"{task:28s} raw {row['raw_steps_per_s']:7.1f} steps/s   demos "
              f"{row['demo_steps_per_s']:7.1f} steps/s   ratio {row['ratio']:.2f}", flush=True)
    suites = {}
    for suite in dict.fromkeys(r["task"].split("/")[0] for r in rows):
        rs = [r for r in rows if r["task"].startswith(suite + "/")]
        suites[suite] = {
            "raw_steps_per_s": float(np.mean([r["raw_steps_per_s"] for r in rs])),
            "demo_steps_per_s": float(np.mean([r["demo_steps_per_s"] for r in rs])),
            "ratio": float(sum(r["demo_steps"] for r in rs)
                           / sum(r["demo_seconds"] for r in rs)
                           / np.mean([r["raw_steps_per_s"] for r in rs])),
        }
    record = {"tasks": rows, "suites": suites, "demos": args.demos, "raw_steps": args.raw_steps,
              "seed": args.seed, "wall_time_s": round(time.perf_counter() - start, 1),
              "kitchen_unavailable": suite_unavailable("kitchen")}
    save_benchmark("sim", record, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
