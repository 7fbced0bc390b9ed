"""What a demonstration set costs to generate, per suite: `results/bench/datasets.json`.

    python -m tools.bench.datasets                  # one set of each suite, reference sizes
    python -m tools.bench.datasets --demos 3        # fewer demos per task (the rate is per demo)

Generates one set (the `generated` source, state observations) of the Meta-World tasks, the
kitchen's Panda twins of the Kinova tasks and the ManiSkill tasks in this process (one
worker), on a set index no table uses, in a folder of its own that is removed afterwards, and reports CPU and wall seconds per demonstration.
`planning.design.plan_cost` multiplies them by the demonstrations a preset's plan asks for
(training seed k of every row trains on set k: S seeds generate S sets of each suite).
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from typing import Any

from icil_paper.config import get_preset
from icil_paper.data import ensure_many
from icil_paper.data.splits import sim_to_real_pairs
from icil_paper.results import bench_path, save_benchmark
from icil_paper.seeding import data_set_seed

BENCH_SET = 49
"""The demonstration set measured (`seeding.DATA_SETS` - 1): no table's seed reaches it."""


def measure(suite: str, tasks: tuple[str, ...], demos: int) -> dict[str, Any]:
    """Generate one set of `demos` demonstrations per task of `tasks` in a temporary folder;
    its CPU and wall seconds, in all and per demonstration."""
    folder = tempfile.mkdtemp(prefix=f"icil-bench-{suite}-")
    try:
        preset = get_preset("reference").replace(data={"root": folder})
        cpu, wall = time.process_time(), time.perf_counter()
        ensure_many(preset, tasks, ["generated"], n=demos, workers=1, progress=False,
                    seed=data_set_seed(preset.seed, BENCH_SET))
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    n = demos * len(tasks)
    return {"tasks": list(tasks), "demos": n, "cpu_s": round(cpu, 2), "wall_s": round(wall, 2),
            "cpu_s_per_demo": round(cpu / n, 4), "wall_s_per_demo": round(wall / n, 4)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.datasets",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--demos", type=int, default=None,
                        help="demonstrations per task (default: the reference preset's)")
    parser.add_argument("--suites", nargs="+", default=["metaworld", "kitchen", "maniskill"],
                        choices=["metaworld", "kitchen", "maniskill"])
    args = parser.parse_args(argv)
    if args.demos is not None and args.demos < 1:
        parser.error("--demos must be at least 1")
    preset = get_preset("reference")
    twins = tuple(sorted(set(sim_to_real_pairs().values())))
    suites = {"metaworld": (preset.data.robocasa_tasks, preset.data.demos_per_task),
              "kitchen": (twins, preset.data.demos_per_task),
              "maniskill": (preset.data.maniskill_tasks,
                            preset.tables.maniskill_demos_per_task or preset.data.demos_per_task)}
    path = bench_path("datasets")  # suites not measured now keep their stored rates
    record = {"suites": json.loads(path.read_text())["suites"] if path.exists() else {}}
    for suite in args.suites:
        tasks, demos = suites[suite]
        record["suites"][suite] = measure(suite, tuple(tasks), args.demos or demos)
        print(suite, record["suites"][suite], flush=True)
    save_benchmark("datasets", record)


if __name__ == "__main__":
    main()
