"""`icil-paper train`: train one policy, write its run folder, store a `train` record."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from icil_paper import sim
from icil_paper.commands import Parser, add_preset_arguments, positive, preset_from_args
from icil_paper.data import load_dataset_file
from icil_paper.data.generate import check_data_folder, demo_path
from icil_paper.fileio import check_env_folder, check_writable, file_sha256
from icil_paper.policies import POLICIES
from icil_paper.registry import check_name
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore
from icil_paper.runspec import run_spec
from icil_paper.sim import all_tasks
from icil_paper.train.loop import training_demos
from icil_paper.train.rundir import POLICY_FILE, RUNS_ENV_VAR, run_dir_for
from icil_paper.train.stored import train_run


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="icil-paper train",
               description="Train a policy (ICRT or a baseline) with an action tokenizer.")
    add_preset_arguments(p)
    p.add_argument("--policy", default="icrt", help=f"one of {', '.join(POLICIES)}")
    p.add_argument("--tokenizer", default=None,
                   help="action tokenizer (icrt: default mlp; act: default none = CVAE)")
    p.add_argument("--tasks", nargs="+", default=None, help="task names (default: see --suite)")
    p.add_argument("--suite", choices=("robocasa", "maniskill"), default="robocasa",
                   help="without --tasks: the preset's RoboCasa-table or Table II tasks")
    p.add_argument("--source", default="generated", help="demonstration source")
    p.add_argument("--obs", choices=("state", "rgb", "rgbd"), default=None,
                   help="observations to learn from (default: the preset's; mcr: rgb)")
    p.add_argument("--dataset", default=None, metavar="FILE",
                   help="train on this robomimic-layout HDF5 file instead of generated data")
    p.add_argument("--obs-keys", nargs="+", default=None,
                   help="with --dataset: observation keys to read (default: data.obs_keys' map)")
    p.add_argument("--run-dir", default=None, help="run folder (default: runs/<preset>/...)")
    resume = p.add_mutually_exclusive_group()
    resume.add_argument("--resume", action="store_true",
                        help="continue from the run folder's last checkpoint (the default)")
    resume.add_argument("--no-resume", action="store_true",
                        help="start over even if a checkpoint exists")
    p.add_argument("--steps", type=positive("--steps"), default=None,
                   help="optimizer steps (the same as --set train.steps=N)")
    p.add_argument("--device", default=None, help="cpu or cuda (default: cuda when available)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def spec_from_args(args: argparse.Namespace, preset):
    """(RunSpec, preset, demos or None) the arguments describe, checked before any work."""
    if args.steps is not None:
        preset = preset.with_overrides([f"train.steps={args.steps}"])
    if args.dataset is not None:
        path = Path(args.dataset)
        if not path.is_file():
            raise FileNotFoundError(f"--dataset {path}: no such file")

        demos = load_dataset_file(path, obs_keys=args.obs_keys)
        tasks = sorted({str(getattr(d, "task", "")) or path.stem for d in demos})
        check_dataset_widths(path, demos)
        spec = run_spec(preset, args.policy, args.tokenizer, tasks=tasks, source=args.source,
                        obs=args.obs)
        digest = file_sha256(path)
        data = spec.data.__class__(tasks=tuple(tasks), source="file", obs=spec.data.obs,
                                   demos_per_task=len(demos), seed=0, dataset=str(path.resolve()),
                                   dataset_sha256=digest,
                                   obs_keys=tuple(args.obs_keys) if args.obs_keys else None)
        return spec.replace(data=data), preset, demos
    tasks = args.tasks or list(getattr(preset.data, f"{args.suite}_tasks"))
    valid = all_tasks()
    for task in tasks:
        check_name("task", task, valid)
    return run_spec(preset, args.policy, args.tokenizer, tasks=tasks, source=args.source,
                    obs=args.obs), preset, None


def check_dataset_widths(path: Path, demos) -> None:
    """Refuse a data set whose action or state widths differ from those of the registered
    task its demos name (demos of unknown tasks are not checked)."""
    known = set(sim.all_tasks())
    for demo in demos:
        task = str(getattr(demo, "task", ""))
        if task not in known:
            continue
        width = int(demo.actions.shape[1])
        if width != sim.ACTION_DIM:
            raise ValueError(f"--dataset {path}: its demos of {task} have {width}-dimensional "
                             f"actions but {task} takes {sim.ACTION_DIM}-dimensional ones; "
                             "pass a data set of that task, or one that names no task of "
                             "this library")
        suite = sim.suite_of(task)
        state = sum(int(demo.obs[k].shape[1]) for k in ("proprio", "object") if k in demo.obs)
        expected = int(sum(sim.obs_dims(suite)))
        if state and state != expected:
            raise ValueError(f"--dataset {path}: its demos of {task} have {state}-dimensional "
                             f"state (proprio + object) but {task} ({suite} suite) gives "
                             f"{expected}; pass --obs-keys that pick that state, or a data "
                             "set that names no task of this library")


def check_outputs(spec, preset, run_dir: Path, explicit_run_dir: bool = False) -> None:
    """Refuse output folders (run, results, data) this process cannot write to."""
    if explicit_run_dir:
        check_writable(run_dir, f"--run-dir {run_dir}", "pass another --run-dir")
    else:
        check_env_folder(RUNS_ENV_VAR, "runs")
        check_writable(run_dir, f"the run folder {run_dir}", "set $ICIL_RUNS or pass --run-dir")
    check_env_folder(RESULTS_ENV_VAR, "results")
    data = spec.data
    if data.dataset is None and not all(demo_path(preset, t, data.source, data.obs).exists()
                                        for t in data.tasks):
        check_data_folder(preset)


def main(argv: list[str] | None = None) -> int:
    """Train (or find trained), write the run folder and a `train` record; say where."""
    args = build_parser().parse_args(argv)
    preset = preset_from_args(args)
    spec, preset, demos = spec_from_args(args, preset)
    run_dir = Path(args.run_dir) if args.run_dir else run_dir_for(spec, preset.name)
    check_outputs(spec, preset, run_dir, explicit_run_dir=bool(args.run_dir))
    if demos is None:  # the data sets (generated where missing, one writer at a time)
        demos = training_demos(spec.data, preset, preset.data.workers, not args.quiet)
    # what only the data's episode lengths decide, before any run folder or training step
    spec.policy.check_episode_length(max(len(d.actions) for d in demos))
    # a stored record is reused only with the policy file it names (`train_run`)
    record = train_run(spec, preset, ResultsStore(preset.name), run_dir=run_dir,
                       force=args.no_resume, resume=not args.no_resume,
                       progress=not args.quiet, device=args.device,
                       data_workers=preset.data.workers, demos=demos)
    m = record["metrics"]
    print(f"{spec.label} trained for {m['steps']} steps on {len(spec.data.tasks)} task(s): "
          f"final loss {m['final_loss']}; policy {run_dir / POLICY_FILE}; run key {spec.key()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
