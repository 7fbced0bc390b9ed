"""Kitchen suite benchmark: expert demo generation speed against raw simulator stepping.

    python -m tools.bench.kitchen              # every kitchen and Kinova task, 3 episodes
    python -m tools.bench.kitchen --quick      # four tasks, 1 episode each
    python -m tools.bench.kitchen --rgb        # also one episode with two-camera images

For each task, in one process and interleaved so that both see the same machine load:

- demo generation: `reset(seed)`, then expert `act` + env `step` until the episode ends,
  collecting every observation dict and action as a data set writer would (state
  observations); steps per second over whole episodes, resets included;
- raw stepping: the same actions replayed through the underlying robosuite env
  (`KitchenSceneEnv.step`: controller and physics, no observation dict, no expert) from the
  same seed. Episodes alternate which side runs first.

The ratio generation / raw says how much of the simulator's speed the suite's wrapper and
experts keep (1.0: none lost), in wall-clock and in CPU seconds (`cpu_ratio`, the steadier
on a shared machine). Writes results/bench/kitchen.json.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from icil_paper.results import save_benchmark
from icil_paper.sim.kitchen import ALL_TASKS, make_kitchen_env, make_kitchen_expert

QUICK_TASKS = ("kitchen/open_drawer", "kitchen/pick_place", "kitchen/twist_knob_on",
               "kinova/open_door")


def _generate(env, expert, seed: int) -> tuple[list[np.ndarray], int, bool]:
    """One expert episode, keeping what a demo writer keeps; returns actions, steps, success."""
    obs, info = env.reset(seed=seed)
    expert.reset(env, obs)
    actions, observations = [], [obs]
    for _ in range(env.horizon):
        action = expert.act(obs)
        obs, _, terminated, truncated, info = env.step(action)
        actions.append(action)
        observations.append(obs)
        if terminated or truncated:
            break
    return actions, len(actions), bool(info["success"])


def _timed_result(fn, *args):
    wall, cpu = time.perf_counter(), time.process_time()
    result = fn(*args)
    return np.array([time.perf_counter() - wall, time.process_time() - cpu]), result


def _timed(fn, *args) -> np.ndarray:
    """(wall seconds, CPU seconds of this process) taken by fn(*args)."""
    return _timed_result(fn, *args)[0]


def _raw(env, seed: int, actions: list[np.ndarray]) -> None:
    """Replay actions through the robosuite env underneath (no wrapper observations)."""
    env.reset(seed=seed)
    raw = env.robosuite_env
    for action in actions:
        raw.step(np.asarray(action, dtype=np.float64))


def bench_task(name: str, episodes: int, seed: int) -> dict:
    env = make_kitchen_env(name, obs="state", seed=seed)
    expert = make_kitchen_expert(name)
    _generate(env, expert, seed)                              # warm-up (JIT, caches)
    gen = np.zeros(2)                                         # (wall s, CPU s)
    raw = np.zeros(2)
    steps, successes = [], 0
    for episode in range(episodes):
        s = seed + 1 + episode
        if episode % 2:                         # odd episodes: raw replay first
            actions, _, _ = _generate(env, expert, s)
            raw += _timed(_raw, env, s, actions)
        elapsed, (actions, n, ok) = _timed_result(_generate, env, expert, s)
        gen += elapsed
        if episode % 2 == 0:
            raw += _timed(_raw, env, s, actions)
        steps.append(n)
        successes += ok
    env.close()
    total = sum(steps)
    return {"task": name, "episodes": episodes, "steps": total,
            "mean_steps_per_demo": total / episodes, "expert_successes": successes,
            "generation_steps_per_s": total / gen[0], "raw_steps_per_s": total / raw[0],
            "ratio": raw[0] / gen[0],
            "generation_steps_per_cpu_s": total / gen[1], "raw_steps_per_cpu_s": total / raw[1],
            "cpu_ratio": raw[1] / gen[1]}


def bench_rgb(name: str, seed: int, size: int = 84) -> dict:
    env = make_kitchen_env(name, obs="rgb", seed=seed, camera_size=size)
    expert = make_kitchen_expert(name)
    elapsed, (_, n, ok) = _timed_result(_generate, env, expert, seed)
    env.close()
    return {"task": name, "camera_size": size, "cameras": 2, "steps": n, "success": ok,
            "generation_steps_per_s": n / elapsed[0], "generation_steps_per_cpu_s": n / elapsed[1]}


def run(tasks: list[str], episodes: int, seed: int, rgb: bool, progress: bool = True) -> dict:
    rows = []
    for name in tasks:
        row = bench_task(name, episodes, seed)
        rows.append(row)
        if progress:
            print(f"  {name:26s} {row['mean_steps_per_demo']:6.1f} steps/demo  generation "
                  f"{row['generation_steps_per_cpu_s']:6.1f}  raw "
                  f"{row['raw_steps_per_cpu_s']:6.1f} steps/CPU-s  ratio {row['cpu_ratio']:.3f}"
                  f"  (wall: {row['generation_steps_per_s']:.1f} / {row['raw_steps_per_s']:.1f})",
                  flush=True)
    total = sum(r["steps"] for r in rows)

    def rate(key: str) -> float:          # steps over summed seconds, across tasks
        return total / sum(r["steps"] / r[key] for r in rows)

    overall = {"steps": total,
               "generation_steps_per_s": rate("generation_steps_per_s"),
               "raw_steps_per_s": rate("raw_steps_per_s"),
               "generation_steps_per_cpu_s": rate("generation_steps_per_cpu_s"),
               "raw_steps_per_cpu_s": rate("raw_steps_per_cpu_s")}
    overall["ratio"] = overall["generation_steps_per_s"] / overall["raw_steps_per_s"]
    overall["cpu_ratio"] = overall["generation_steps_per_cpu_s"] / overall["raw_steps_per_cpu_s"]
    overall["median_task_cpu_ratio"] = float(np.median([r["cpu_ratio"] for r in rows]))
    record = {
        "benchmark": "kitchen",
        "seed": seed,
        "episodes_per_task": episodes,
        "tasks": rows,
        "overall": overall,
    }
    if rgb:
        record["rgb"] = bench_rgb(tasks[0], seed)
        if progress:
            print(f"  rgb ({tasks[0]}, 2 cameras 84x84): "
                  f"{record['rgb']['generation_steps_per_s']:.1f} steps/s", flush=True)
    return record


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.kitchen",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="four tasks, one episode each")
    parser.add_argument("--episodes", type=int, default=None, help="episodes per task")
    parser.add_argument("--tasks", nargs="*", help="task names (default: all, or the quick set)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rgb", action="store_true", help="also time image observations")
    parser.add_argument("--out", help="output JSON (default results/bench/kitchen.json)")
    args = parser.parse_args(argv)
    tasks = list(args.tasks or (QUICK_TASKS if args.quick else ALL_TASKS))
    episodes = args.episodes or (1 if args.quick else 3)
    start = time.perf_counter()
    record = run(tasks, episodes, args.seed, args.rgb)
    record["quick"] = args.quick
    record["wall_time_s"] = round(time.perf_counter() - start, 1)
    save_benchmark("kitchen", record, args.out)
    o = record["overall"]
    print(f"overall: generation {o['generation_steps_per_cpu_s']:.1f}, raw "
          f"{o['raw_steps_per_cpu_s']:.1f} steps per CPU second, ratio {o['cpu_ratio']:.3f} "
          f"(median over tasks {o['median_task_cpu_ratio']:.3f}; wall clock: "
          f"{o['generation_steps_per_s']:.1f} / {o['raw_steps_per_s']:.1f} steps/s, ratio "
          f"{o['ratio']:.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
