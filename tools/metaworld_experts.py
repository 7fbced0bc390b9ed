"""Measure the Meta-World suite's scripted experts and env speed.

    python -m tools.metaworld_experts                   # the 13 family tasks + ML45 test
    python -m tools.metaworld_experts --tasks all --json /tmp/metaworld_experts.json

For every task and scene distribution: expert success on `--episodes` layouts (seeds
`--first-seed`, +1, ...), mean and longest successful episode (steps), the share of steps whose
raw expert action has an entry outside [-1, 1], and whether every observation lies in the
declared space; where the episodes suggest another horizon than the task's (the rule of
`icil_paper.sim.metaworld.tasks.DEFAULT_HORIZON`), it says so. Then env steps per second with
state observations and with rgb (two cameras, 84 x 84).
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

from icil_paper.sim.metaworld import (
    METAWORLD_TASKS,
    ML45_HELD_OUT,
    ROBOCASA_TASKS,
    SCENE_DISTRIBUTIONS,
    TASKS,
    make_metaworld_env,
    make_metaworld_expert,
)


def run_task(task: str, scenes: str, seeds: range, horizon: int | None = None) -> dict:
    """Expert episodes of one task on the layouts of `seeds` (at the task's horizon, or
    `horizon` steps)."""
    env = make_metaworld_env(task, scenes=scenes, horizon=horizon)
    expert = make_metaworld_expert(task)
    successes, lengths, outside, total, in_space = [], [], 0, 0, True
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        expert.reset(env, obs)
        in_space &= obs in env.observation_space
        for _ in range(env.horizon):
            raw = np.asarray(expert.policy.get_action(env.raw_observation()))
            outside += int(np.any(np.abs(raw) > 1.0))
            total += 1
            obs, _, terminated, truncated, info = env.step(expert.act(obs))
            in_space &= obs in env.observation_space
            if terminated or truncated:
                break
        successes.append(bool(info["success"]))
        if info["success"]:
            lengths.append(env.steps)
    env.close()
    return {"task": task, "scenes": scenes, "episodes": len(seeds),
            "success": float(np.mean(successes)),
            "mean_len": float(np.mean(lengths)) if lengths else None,
            "max_len": int(max(lengths)) if lengths else None,
            "p99_len": float(np.percentile(lengths, 99)) if lengths else None,
            "clipped_share": outside / max(total, 1), "obs_in_space": bool(in_space),
            "failed_seeds": [s for s, ok in zip(seeds, successes, strict=True) if not ok]}


def suggested_horizon(rows: list[dict]) -> int:
    """The smallest multiple of 100 in [200, 500] that is at least 1.1 times the largest 99th
    percentile of successful episode lengths in `rows` (one task's scene distributions)."""
    p99 = max((r["p99_len"] for r in rows if r["p99_len"]), default=0.0)
    return int(min(max(np.ceil(1.1 * p99 / 100) * 100, 200), 500))


def steps_per_second(task: str, obs: str, steps: int) -> float:
    """Env steps per second (random actions, resets every 200 steps), after one warm-up."""
    env = make_metaworld_env(task, obs=obs)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    env.step(rng.uniform(-1, 1, 7))
    start = time.perf_counter()
    for t in range(steps):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 7))
        if terminated or truncated or (t + 1) % 200 == 0:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", default="families",
                        help="'families' (the 13 RoboCasa-family tasks and ML45's 5 test "
                             "tasks), 'all', or comma-separated task names")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--speed-steps", type=int, default=2000,
                        help="steps of the speed measurement (0: skip it)")
    parser.add_argument("--horizon", type=int,
                        help="steps per episode instead of each task's horizon (e.g. 500, "
                             "Meta-World's own limit, to see how long the experts need)")
    parser.add_argument("--json", help="write the results to this JSON file")
    args = parser.parse_args()
    if args.tasks == "families":
        tasks = (*ROBOCASA_TASKS, *ML45_HELD_OUT)
    elif args.tasks == "all":
        tasks = TASKS
    else:
        tasks = tuple(t.strip() for t in args.tasks.split(","))
    seeds = range(args.first_seed, args.first_seed + args.episodes)

    warnings.filterwarnings("ignore", message=r"Constant\(s\) may be too high")
    rows = []
    print(f"{'task':36s} {'scenes':9s} {'success':>7s} {'mean':>6s} {'max':>4s} "
          f"{'clip%':>6s} space  failed seeds")
    horizons = {}
    for task in tasks:
        for scenes in SCENE_DISTRIBUTIONS:
            row = run_task(task, scenes, seeds, args.horizon)
            rows.append(row)
            mean = f"{row['mean_len']:.1f}" if row["mean_len"] else "-"
            print(f"{task:36s} {scenes:9s} {row['success']:7.2f} {mean:>6s} "
                  f"{row['max_len'] or '-':>4} {100 * row['clipped_share']:6.1f} "
                  f"{'ok' if row['obs_in_space'] else 'OUT':5s}  {row['failed_seeds']}",
                  flush=True)
        horizons[task] = suggested_horizon([r for r in rows if r["task"] == task])
        if horizons[task] != METAWORLD_TASKS[task].horizon:
            print(f"{task}: horizon {METAWORLD_TASKS[task].horizon}, these episodes suggest "
                  f"{horizons[task]}")
    lengths = [r["max_len"] for r in rows if r["max_len"]]
    print(f"longest successful episode: {max(lengths)} steps; lowest success: "
          f"{min(r['success'] for r in rows):.2f}")
    speed = {}
    if args.speed_steps:
        for obs, steps in (("state", args.speed_steps), ("rgb", max(args.speed_steps // 10, 50))):
            speed[obs] = steps_per_second("metaworld/drawer-open", obs, steps)
            print(f"steps/s with obs={obs!r}: {speed[obs]:.0f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"episodes": args.episodes, "first_seed": args.first_seed,
                       "horizon": args.horizon,
                       "rows": rows, "suggested_horizons": horizons,
                       "steps_per_second": speed}, f, indent=1)


if __name__ == "__main__":
    main()
