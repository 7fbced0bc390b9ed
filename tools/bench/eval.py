"""Evaluation throughput: the policy's rollouts against the simulator stepping alone, in one run.

    python -m tools.bench.eval                   # 11 kitchen tasks x 4 episodes, 2 workers
    python -m tools.bench.eval --max-steps 0     # whole episodes (the tasks' horizons)

The policy is ICRT + LipVQ-VAE at the small preset's size after a short training
(`--train-steps` on each task's first `--demos` demonstrations; stored in `runs/small/` and
reused). Its evaluation is cut into the rollout engine's lockstep groups
(`icil_paper.eval.rollouts`), and each group runs twice in a row on the same worker and envs,
so that both sides see the same machine load:

    policy:  `rollouts.run_group`, one batched ICRT forward pass per step;
    raw:     the same envs reset from the same seeds and stepped with zero actions, each
             episode for exactly the steps the policy's episode took.

Env construction is timed apart and counted in both; a side's wall time is its slowest
worker's. Reported: each side's steps per second, `ratio` = policy / raw (1.0: the policy
costs nothing), `worker_scaling` (`--workers` workers over one; `raw_worker_scaling`, the
simulator's own) and CPU seconds (`cpu_ratio`). `--device cuda` puts the policy on the GPU.
Writes results/bench/eval.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import multiprocessing as mp
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from icil_paper.config import get_preset
from icil_paper.eval import plan_episodes, prompt_pool
from icil_paper.eval.rollouts import (
    EnvSetup,
    WorkerState,
    default_batch_size,
    group_jobs,
    rollout_batch,
    run_group,
    worker_state,
)
from icil_paper.results import save_benchmark
from icil_paper.runspec import EvalSpec, run_spec
from icil_paper.seeding import cpu_threads, seed_everything
from icil_paper.sim import suite_unavailable, tasks_of
from icil_paper.train import POLICY_FILE, load_policy, run_dir_for, train_policy

KITCHEN_IMPORTS = ("torch", "icil_paper.sim.kitchen.env", "icil_paper.policies.icrt")
"""What a worker imports before anything is timed."""


class ZeroActions:
    """A policy that always acts with zeros (the raw side)."""

    uses_prompt = False
    action_dim = 7

    def reset_batch(self, prompts: Any, instructions: Any = None) -> None:
        pass

    def select_actions(self, obs: Any, rows: Any = None) -> np.ndarray:
        return np.zeros((len(obs), self.action_dim), np.float32)


def _clock() -> np.ndarray:
    return np.array([time.perf_counter(), time.process_time()])


def paired_group(job: Any, state: Any = None) -> dict[str, Any]:
    """Run one group with the policy, then the same episodes raw (see the module docstring),
    with `state`'s envs (default: this worker process's); returns the process id, the seconds
    (wall, CPU) of env construction, of the policy side and of the raw side, and the policy's
    per-episode results."""
    state = state or worker_state()
    t0 = _clock()
    envs = state.envs_for(job.env, job.episodes)  # built where this worker lacks them
    t1 = _clock()
    rows = run_group(state, job)
    t2 = _clock()
    rollout_batch(ZeroActions(), envs, [ep.seed for ep in job.episodes],
                  max_steps=[row["steps"] for row in rows])
    t3 = _clock()
    return {"pid": os.getpid(), "build": (t1 - t0).tolist(), "policy": (t2 - t1).tolist(),
            "raw": (t3 - t2).tolist(), "rows": rows}


def _start_worker() -> None:
    import torch

    torch.set_num_threads(1)  # the workers share the cores


def _warm(modules: tuple[str, ...]) -> int:
    for name in modules:
        importlib.import_module(name)
    time.sleep(0.5)  # long enough that every worker takes one
    return os.getpid()


def paired_phase(policy: Any, episodes: list[Any], prompts: dict[int, Any],
                 workers: int) -> dict[str, Any]:
    """Every group of the engine's plan for `workers`, paired, on fresh warmed-up workers
    (or in this process for one); the per-side figures of the module docstring."""
    batch = default_batch_size(episodes)
    setup = EnvSetup("state")
    start = time.perf_counter()
    if workers == 1:
        state = WorkerState()  # no envs yet, as a new worker
        try:
            with cpu_threads(1):
                results = [paired_group(job, state)
                           for job in group_jobs(episodes, prompts, policy, setup, batch)]
        finally:
            state.close()
    else:
        with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"),
                                 initializer=_start_worker) as pool:
            list(pool.map(_warm, [KITCHEN_IMPORTS] * workers))
            start = time.perf_counter()
            futures = [pool.submit(paired_group, job)
                       for job in group_jobs(episodes, prompts, policy, setup, batch)]
            results = [f.result() for f in futures]
    end_to_end = time.perf_counter() - start
    per_worker: dict[int, dict[str, np.ndarray]] = {}
    for r in results:
        w = per_worker.setdefault(r["pid"], {k: np.zeros(2) for k in ("build", "policy", "raw")})
        for k in ("build", "policy", "raw"):
            w[k] += r[k]
    rows = [row for r in results for row in r["rows"]]
    steps = int(sum(row["steps"] for row in rows))
    out: dict[str, Any] = {"workers": workers, "batch_size": batch, "groups": len(results),
                           "steps": steps, "successes": int(sum(r["success"] for r in rows)),
                           "end_to_end_s": round(end_to_end, 2),
                           "load_1min_after": os.getloadavg()[0]}
    for side in ("policy", "raw"):
        totals = [w["build"] + w[side] for w in per_worker.values()]
        wall = max(t[0] for t in totals)
        cpu = sum(t[1] for t in totals)
        out[side] = {"seconds": round(wall, 2), "steps_per_s": steps / wall,
                     "cpu_seconds": round(cpu, 2), "cpu_ms_per_step": 1000 * cpu / steps}
    out["env_build_s"] = round(max(w["build"][0] for w in per_worker.values()), 2)
    out["ratio"] = out["policy"]["steps_per_s"] / out["raw"]["steps_per_s"]
    out["cpu_ratio"] = out["raw"]["cpu_ms_per_step"] / out["policy"]["cpu_ms_per_step"]
    out["outcomes"] = [(row["success"], row["steps"]) for row in rows]
    return out


def bench_run(tasks: list[str], demos: int, train_steps: int, seed: int):
    """The benchmark's RunSpec: ICRT + LipVQ-VAE, small preset, a short training."""
    preset = get_preset("small", seed=seed)
    spec = run_spec(preset, "icrt", "lipvq", tasks=tasks)
    return spec.replace(data=dataclasses.replace(spec.data, demos_per_task=demos),
                        train=dataclasses.replace(spec.train, steps=train_steps,
                                                  warmup_steps=min(spec.train.warmup_steps,
                                                                   train_steps // 5)))


def trained_policy(run: Any, progress: bool) -> tuple[Any, dict[str, Any]]:
    """The run's policy file, trained first where missing; and how it was obtained."""
    folder = run_dir_for(run, "small")
    start = time.perf_counter()
    trained = not (folder / POLICY_FILE).exists()
    if trained:
        train_policy(run, run_dir=folder, progress=progress, preset="small", data_workers=2)
    return load_policy(folder), {"run_dir": str(folder), "trained_now": trained,
                                 "train_steps": run.train.steps,
                                 "demos_per_task": run.data.demos_per_task,
                                 "seconds": round(time.perf_counter() - start, 1)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.eval",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="*", help="tasks (default: the kitchen suite's 11)")
    parser.add_argument("--episodes", type=int, default=4, help="episodes per task")
    parser.add_argument("--max-steps", type=int, default=80,
                        help="step limit per episode (0: each task's horizon)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--demos", type=int, default=3,
                        help="demonstrations per task (training data and prompt pool)")
    parser.add_argument("--train-steps", type=int, default=200, help="training steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="cpu", help="where the policy acts (cpu, cuda)")
    parser.add_argument("--skip-one-worker", action="store_true",
                        help="leave out the one-worker run (no scaling figures)")
    parser.add_argument("--out", help="output JSON (default results/bench/eval.json)")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if min(args.episodes, args.workers, args.demos, args.train_steps) < 1 or args.max_steps < 0:
        print("error: --episodes, --workers, --demos and --train-steps must be positive and "
              "--max-steps at least 0", file=sys.stderr)
        return 2
    problem = suite_unavailable("kitchen")
    if problem:
        print(f"error: the kitchen suite cannot run here ({problem})", file=sys.stderr)
        return 2
    seed_everything(args.seed)
    import torch

    torch.set_num_threads(1)
    started = time.perf_counter()
    tasks = args.tasks or list(tasks_of("kitchen"))
    run = bench_run(tasks, args.demos, args.train_steps, args.seed)
    policy, training = trained_policy(run, progress=not args.quiet)
    policy = policy.to(args.device).eval()
    max_steps = args.max_steps or None
    specs = [EvalSpec(task=t, episodes=args.episodes, seed=args.seed, max_steps=max_steps)
             for t in tasks]
    pools = {i: prompt_pool(ev, "state", args.demos, run.data.seed, "small", progress=False)
             for i, ev in enumerate(specs)}
    episodes = [ep for i, ev in enumerate(specs)
                for ep in plan_episodes(ev, len(pools[i]), policy.config.prompt_demos, i)]

    runs = {"workers": paired_phase(policy, episodes, pools, args.workers)}
    if not args.skip_one_worker:
        runs["one_worker"] = paired_phase(policy, episodes, pools, 1)
    main_run = runs["workers"]
    record: dict[str, Any] = {
        "tasks": tasks, "episodes_per_task": args.episodes, "max_steps": max_steps,
        "workers": args.workers, "seed": args.seed, "device": args.device,
        "policy": "icrt+lipvq (small preset size)", "training": training,
        "raw_steps_per_s": main_run["raw"]["steps_per_s"],
        "policy_steps_per_s": main_run["policy"]["steps_per_s"],
        "ratio": main_run["ratio"], "cpu_ratio": main_run["cpu_ratio"],
        "success_rate": main_run["successes"] / len(episodes),
    }
    if "one_worker" in runs:
        one = runs["one_worker"]
        record.update(
            worker_scaling=main_run["policy"]["steps_per_s"] / one["policy"]["steps_per_s"],
            raw_worker_scaling=main_run["raw"]["steps_per_s"] / one["raw"]["steps_per_s"],
            one_worker_ratio=one["ratio"],
            outcomes_equal_across_workers=one["outcomes"] == main_run["outcomes"])
    for r in runs.values():
        r.pop("outcomes")
    record["runs"] = runs
    record["wall_time_s"] = round(time.perf_counter() - started, 1)
    for name, r in runs.items():
        for side in ("policy", "raw"):
            f = r[side]
            print(f"{name:10s} {side:6s} {r['workers']} worker(s): {r['steps']} steps in "
                  f"{f['seconds']:.1f} s = {f['steps_per_s']:.1f} steps/s "
                  f"({f['cpu_ms_per_step']:.2f} CPU ms/step)")
    print(f"ratio policy/raw {record['ratio']:.2f} (CPU time {record['cpu_ratio']:.2f})"
          + (f"; {args.workers} workers / 1: policy {record['worker_scaling']:.2f}x, "
             f"raw {record['raw_worker_scaling']:.2f}x" if "worker_scaling" in record else ""))
    save_benchmark("eval", record, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
