"""`icil-paper eval`: roll out a trained run on each task; one stored `eval` record per task."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from icil_paper.commands import Parser, add_preset_arguments, positive, preset_from_args
from icil_paper.data.generate import check_data_folder, demo_path
from icil_paper.eval.outcomes import check_policy_fits
from icil_paper.eval.stored import evaluate_run
from icil_paper.fileio import check_env_folder
from icil_paper.registry import check_name
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore, results_root
from icil_paper.runspec import eval_spec, run_spec
from icil_paper.sim import all_tasks
from icil_paper.train.rundir import CONFIG_FILE, load_policy, read_run_spec, run_dir_for
from icil_paper.train.stored import trusted_policy


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="icil-paper eval", description="Roll out a trained policy; store its success rate.")
    add_preset_arguments(p)
    p.add_argument("--run-dir", default=None,
                   help="folder of a training run (default: the one the options below name)")
    p.add_argument("--policy", default="icrt", help="policy name, to find the default run folder")
    p.add_argument("--tokenizer", default=None, help="tokenizer name, to find the default run folder")
    p.add_argument("--tasks", nargs="+", default=None,
                   help="tasks to evaluate on (default: the tasks the policy was trained on)")
    p.add_argument("--train-tasks", nargs="+", default=None,
                   help="the training run's tasks, to find its folder (default: see --suite)")
    p.add_argument("--suite", choices=("robocasa", "maniskill"), default="robocasa",
                   help="without --train-tasks: the preset's RoboCasa-table or Table II tasks")
    p.add_argument("--source", default="generated", help="the training run's demonstration source")
    p.add_argument("--prompt-source", default="generated", help="where prompt demonstrations come from")
    p.add_argument("--eval-seed", type=int, default=None,
                   help="evaluation seed (default: the preset's seed)")
    p.add_argument("--episodes", type=positive("--episodes"), default=None,
                   help="rollouts per task (default: the preset's eval.episodes_per_task)")
    p.add_argument("--workers", type=positive("--workers"), default=None,
                   help="no effect, kept for older scripts (rollouts run batched in-process)")
    p.add_argument("--max-steps", type=positive("--max-steps"), default=None,
                   help="step limit per rollout (default: the preset's, else the task's horizon)")
    p.add_argument("--record", action="store_true", help="write a rerun recording of each rollout")
    p.add_argument("--force", action="store_true", help="recompute a stored result")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def _check_outputs(run: Any, policy: Any, tasks: Sequence[str], prompt_source: str,
                   preset: Any) -> None:
    """Refuse, before any rollout, results and data folders this process cannot write to."""
    check_env_folder(RESULTS_ENV_VAR, "results")
    if policy.uses_prompt and not all(demo_path(preset, t, prompt_source, run.data.obs).exists()
                                      for t in tasks):
        check_data_folder(preset)


def main(argv: list[str] | None = None) -> int:
    """`icil-paper eval`: evaluate a trained run on each task; one `eval` record per task."""
    args = build_parser().parse_args(argv)
    preset = preset_from_args(args)
    valid = all_tasks()
    for task in (args.tasks or []) + (args.train_tasks or []):
        check_name("task", task, valid)
    if args.run_dir:
        run_dir = Path(args.run_dir)
        config_path = run_dir / CONFIG_FILE
        if not config_path.exists():
            raise FileNotFoundError(f"{run_dir} is not a training run folder (no {CONFIG_FILE})")
        run = read_run_spec(run_dir)
    else:
        train_tasks = args.train_tasks or list(getattr(preset.data, f"{args.suite}_tasks"))
        run = run_spec(preset, args.policy, args.tokenizer, tasks=train_tasks, source=args.source)
        run_dir = run_dir_for(run, preset.name)
    policy = load_policy(run_dir)
    tasks = args.tasks or list(run.data.tasks)
    for task in tasks:  # before any prompt data set is generated or env started
        check_policy_fits(policy, task)
    _check_outputs(run, policy, tasks, args.prompt_source, preset)
    store = ResultsStore(preset.name)
    # only the policy its train record names, trained for this run's key (else set aside
    # and computed again): an evaluation is never stored under another run's key
    policy = trusted_policy(run, preset, store, run_dir, progress=not args.quiet,
                            data_workers=preset.data.workers)
    record_dir = results_root() / preset.name / "recordings" if args.record else None
    for task in tasks:
        ev = eval_spec(preset, task, episodes=args.episodes, seed=args.eval_seed,
                       prompt_source=args.prompt_source, max_steps=args.max_steps)
        record = evaluate_run(run, ev, policy, store, preset, record_dir,
                              force=args.force, progress=not args.quiet)
        m = record["metrics"]
        print(f"{run.label} on {task} (prompts: {args.prompt_source}): success "
              f"{m['success_rate']:.3f} [{m['ci_low']:.3f}, {m['ci_high']:.3f}] over "
              f"{m['episodes']} episodes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
