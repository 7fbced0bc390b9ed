"""`icil-paper demos`: generate (resumably, in parallel) or check demonstration data sets.

    icil-paper demos --task kitchen/open_drawer --source generated --n 10 [--preset small] [--workers 2]
    icil-paper demos --task all --source all          # every task and source of the preset
    icil-paper demos --check path/to/file.hdf5 [--action-dim 7]
    icil-paper demos --list                           # task names and data set paths

A damaged data set file is set aside, named in a warning, and generated again.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from icil_paper.commands import Parser, add_preset_arguments, preset_from_args
from icil_paper.data.generate import check_data_folder, demo_path, ensure_many, preset_tasks
from icil_paper.data.hdf5 import DatasetError, load_demos
from icil_paper.data.sources import SOURCES
from icil_paper.seeding import seed_everything
from icil_paper.sim import all_tasks


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="icil-paper demos",
        description="Generate demonstration data sets (robomimic HDF5), resuming interrupted "
                    "runs, or validate a data set file.",
    )
    parser.add_argument("--task", action="append",
                        help="task name (repeatable), or 'all' for every task of the preset")
    parser.add_argument("--source", action="append", choices=(*SOURCES, "all"),
                        help="demonstration source (repeatable; default: generated)")
    parser.add_argument("--n", type=int, help="demos per task and source (default: the preset's)")
    add_preset_arguments(parser)  # --preset, --seed (the scenes' base seed), --set
    parser.add_argument("--workers", type=int, help="processes (default: the preset's)")
    parser.add_argument("--obs", choices=("state", "rgb", "rgbd"),
                        help="observation kind (default: the preset's data.obs)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--check", metavar="FILE", help="validate a data set file and summarize it")
    parser.add_argument("--action-dim", type=int, help="with --check: expected action width")
    parser.add_argument("--list", action="store_true", help="list tasks and data set paths")
    return parser


def _check(path: str, action_dim: int | None) -> int:
    try:
        demos = load_demos(path, action_dim=action_dim, images=False)
    except DatasetError as exc:
        print(f"invalid: {exc}", file=sys.stderr)
        return 1
    lengths = np.array([len(d) for d in demos])
    tasks = sorted({d.task for d in demos})
    print(f"{path}: {len(demos)} demos, {lengths.sum()} steps (length {lengths.min()}-"
          f"{lengths.max()}, mean {lengths.mean():.1f}); tasks {tasks}; "
          f"action dim {demos[0].actions.shape[1]}; proprio {demos[0].obs['proprio'].shape[1]}, "
          f"object {demos[0].obs['object'].shape[1]}")
    return 0


def _numbers_problem(args: argparse.Namespace) -> str | None:
    """The first out-of-range number on the command line, as a sentence with the fix."""
    for flag, value, low in (("--n", args.n, 1), ("--workers", args.workers, 1),
                             ("--seed", args.seed, 0), ("--action-dim", args.action_dim, 1)):
        if value is not None and value < low:
            return f"{flag} must be at least {low}, got {value}"
    return None


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    problem = _numbers_problem(args)
    if problem:
        print(f"icil-paper demos: error: {problem}", file=sys.stderr)
        return 2
    if args.check:
        return _check(args.check, args.action_dim)
    preset = preset_from_args(args)
    seed_everything(preset.seed)
    sources = args.source or ["generated"]
    sources = list(SOURCES) if "all" in sources else list(dict.fromkeys(sources))
    tasks = args.task or []
    if args.list:
        for task in all_tasks():
            paths = ", ".join(str(demo_path(preset, task, s, args.obs)) for s in SOURCES)
            print(f"{task:32s} {paths}")
        return 0
    if not tasks:
        build_parser().error("give --task (or --task all), --check FILE or --list")
    if "all" in tasks:
        tasks = list(preset_tasks(preset, available=True))
    obs = args.obs or preset.data.obs
    if not all(demo_path(preset, t, s, obs).exists() for t in tasks for s in sources):
        check_data_folder(preset)  # a folder it cannot write to: one line, before any work
    paths = ensure_many(preset, tasks, sources, n=args.n, workers=args.workers,
                        progress=not args.no_progress, obs=args.obs, full_check=True)
    for (task, source), path in paths.items():
        print(f"{task} [{source}]: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
