"""Measure every expert's success rate over random seeds and record it.

    python -m icil_paper.data.experts --suites kitchen kinova maniskill --seeds 50

For each task and random scene seed: the expert's episode, an open-loop replay of its
actions, the `human` source's episode and, where the suite has `human` scenes, the expert
on those. Each suite's record goes to `results/experts/<suite>.json`; the exit status is 1
when an expert rate is below `REQUIRED_RATE`.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from icil_paper.data.generate import imap_jobs, worker_init
from icil_paper.data.sources import ExpertSource, expert_rollout, make_source, source_env_options
from icil_paper.fileio import atomic_write_json
from icil_paper.results import results_root
from icil_paper.setup.provenance import git_state, host_info, package_versions
from icil_paper.sim import SUITES, make_env, make_expert, tasks_of

REQUIRED_RATE = 0.9
_CACHE: dict[str, Any] = {}


def _get(task: str) -> tuple[Any, Any, Any, Any]:
    """(env, replay env, expert, env of the human source's scenes or None)."""
    if task not in _CACHE:
        options = source_env_options("human", task)
        _CACHE[task] = (make_env(task, obs="state", seed=0), make_env(task, obs="state", seed=0),
                        make_expert(task),
                        make_env(task, obs="state", seed=0, **options) if options else None)
    return _CACHE[task]


def measure_one(job: tuple[str, int, bool]) -> dict[str, Any]:
    """The episodes of one (task, seed, human) job (module docstring)."""
    task, seed, human = job
    env, replay_env, expert, human_env = _get(task)
    start = time.perf_counter()
    demo, ok = expert_rollout(env, ExpertSource(expert), seed, record_states=False)
    out: dict[str, Any] = {"task": task, "seed": seed, "success": ok, "length": len(demo),
                           "expert_s": time.perf_counter() - start}
    if hasattr(expert, "planned_success"):
        out["planned_success"] = bool(expert.planned_success)
    replay_ok = None  # only successful episodes become demos, so only they are replayed
    if ok:
        replay_ok = False
        replay_env.reset(seed=seed)
        for action in demo.actions:
            *_, info = replay_env.step(action)
            if info["success"]:
                replay_ok = True
                break
    out["replay_success"] = replay_ok
    if human_env is not None:
        sdemo, sok = expert_rollout(human_env, ExpertSource(expert), seed, record_states=False)
        out["human_scenes_success"] = sok
        out["human_scenes_length"] = len(sdemo)
    if human:
        hdemo, hok = expert_rollout(human_env or env, make_source("human", task, expert), seed,
                                    source="human", record_states=False)
        out["human_success"] = hok
        out["human_length"] = len(hdemo)
    return out


def _outcome(rs: list[dict[str, Any]], ok: str, length: str) -> tuple[float, list, float | None]:
    """(success rate, failed seeds, mean length of the successes) of one kind of episode."""
    won = [r[length] for r in rs if r[ok]]
    return (len(won) / len(rs), [r["seed"] for r in rs if not r[ok]],
            float(np.mean(won)) if won else None)


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-task rates from the per-seed rows."""
    tasks: dict[str, Any] = {}
    for task in dict.fromkeys(r["task"] for r in rows):
        rs = [r for r in rows if r["task"] == task]
        ok = [r for r in rs if r["success"]]
        rate, failed, mean = _outcome(rs, "success", "length")
        entry = {
            "episodes": len(rs),
            "expert_success_rate": rate,
            "failed_seeds": failed,
            "mean_length": mean,
            "max_length": int(max(r["length"] for r in ok)) if ok else None,
            "replay_success_rate": (float(np.mean([r["replay_success"] for r in ok]))
                                    if ok else None),
            "seconds_per_episode": float(np.mean([r["expert_s"] for r in rs])),
        }
        if "planned_success" in rs[0]:
            entry["planned_success_rate"] = float(np.mean([r["planned_success"] for r in rs]))
        if "human_scenes_success" in rs[0]:
            (entry["expert_success_rate_human_scenes"], entry["failed_seeds_human_scenes"],
             entry["mean_length_human_scenes"]) = _outcome(rs, "human_scenes_success",
                                                           "human_scenes_length")
        if "human_success" in rs[0]:
            entry["human_success_rate"], _, entry["human_mean_length"] = _outcome(
                rs, "human_success", "human_length")
        entry["meets_required_rate"] = (
            entry["expert_success_rate"] >= REQUIRED_RATE
            and entry.get("expert_success_rate_human_scenes", 1.0) >= REQUIRED_RATE)
        tasks[task] = entry
    return tasks


def measure(suite: str, n_seeds: int = 50, seed: int = 0, workers: int = 2,
            human: bool = True, tasks: list[str] | None = None,
            progress: bool = True) -> dict[str, Any]:
    """Run the measurement and return the record (not written)."""
    tasks = list(tasks or tasks_of(suite))
    if not tasks:
        raise RuntimeError(f"suite {suite!r} has no importable tasks")
    seeds = np.random.default_rng(seed).integers(0, 2**31 - 1, size=n_seeds).tolist()
    jobs = [(t, int(s), human) for t in tasks for s in seeds]
    start = time.perf_counter()
    rows = []
    bar = tqdm(total=len(jobs), desc=f"experts {suite}", disable=not progress)
    if workers <= 1:
        worker_init()
    for row in imap_jobs(measure_one, jobs, workers):
        rows.append(row)
        bar.update()
    bar.close()
    rows.sort(key=lambda r: (tasks.index(r["task"]), seeds.index(r["seed"])))
    return {"suite": suite, "n_seeds": n_seeds, "seed": seed, "seeds": seeds,
            "required_rate": REQUIRED_RATE, "tasks": summarize(rows),
            "wall_time_s": round(time.perf_counter() - start, 1)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icil_paper.data.experts",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--suites", "--suite", nargs="+", choices=SUITES, default=["maniskill"],
                        help="suites to measure (default: maniskill)")
    parser.add_argument("--seeds", type=int, default=50, help="random scene seeds per task")
    parser.add_argument("--seed", type=int, default=0, help="seed of the seed draw")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--tasks", nargs="*", help="only these tasks (of a single suite)")
    parser.add_argument("--no-human", action="store_true", help="skip the human-source episodes")
    parser.add_argument("--out", help="output JSON of a single suite (default: results/experts/)")
    args = parser.parse_args(argv)
    if (args.out or args.tasks) and len(args.suites) > 1:
        parser.error("--out and --tasks take a single suite; pass one --suites name")
    rows = []
    for suite in args.suites:
        record = measure(suite, args.seeds, args.seed, args.workers, not args.no_human,
                         args.tasks)
        record.update(git_commit=git_state()["commit"], packages=package_versions(),
                      host=host_info())
        out = args.out or results_root() / "experts" / f"{suite}.json"
        atomic_write_json(out, record)
        print(f"wrote {out}")
        rows += list(record["tasks"].items())

    def rate(value: float | None) -> str:
        return "" if value is None else f"{value:.2f}"

    print(f"\n{'task':28s} {'expert':>7s} {'h-scenes':>8s} {'replay':>7s} {'planned':>8s} "
          f"{'human':>7s} {'mean len':>9s}  failed seeds")
    for task, e in rows:
        flag = "" if e["meets_required_rate"] else f"  BELOW {REQUIRED_RATE}"
        failed = e["failed_seeds"] + [f"h{s}" for s in e.get("failed_seeds_human_scenes", [])]
        print(f"{task:28s} {e['expert_success_rate']:7.2f} "
              f"{rate(e.get('expert_success_rate_human_scenes')):>8s} "
              f"{rate(e['replay_success_rate']):>7s} "
              f"{rate(e.get('planned_success_rate')):>8s} {rate(e.get('human_success_rate')):>7s} "
              f"{e['mean_length'] or float('nan'):9.1f}  {failed}{flag}")
    return 0 if all(e["meets_required_rate"] for _, e in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
