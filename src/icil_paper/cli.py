"""`icil-paper`: the command line of the companion.

Each subcommand is a module-level `main(argv)` imported only when its command runs
(`command_main`), so that `--help` loads neither torch nor a simulator. A user error ends the
command with one line and exit status 2 (`commands.run_module`); `--debug` shows the traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from functools import partial

from icil_paper.commands import Parser, run_module
from icil_paper.config import PRESET_NAMES, REFERENCE_BUDGET_HOURS, active_preset_name
from icil_paper.plugins import load_plugins
from icil_paper.setup.envcheck import environment_report, format_report

SUBCOMMANDS = {
    "demos": "generate demonstration data sets (robomimic HDF5)",
    "train": "train a policy (ICRT or a baseline) with a tokenizer",
    "eval": "roll out a trained policy and store its success rate",
    "tables": "print the paper's tables and claims from the results store",
    "reproduce": "run every experiment of a preset (then `make book`)",
    "compare": "a tokenizer against LipVQ-VAE on Table I's protocol: difference, verdict, power",
    "plan": "the seeds, cells and CPU-hours that would decide every undecided claim, and the "
            "run that computes them",
    "export-tokenizer": "write a trained policy's tokenizer as a portable folder (safetensors)",
}
"""subcommand -> its one-line help (`command_main` imports what runs it)."""


def command_main(command: str) -> Callable[[list[str]], int | None]:
    """The `main(argv)` of a subcommand, imported when the command runs."""
    if command == "demos":
        from icil_paper.data.cli import main
    elif command == "train":
        from icil_paper.train.cli import main
    elif command == "eval":
        from icil_paper.eval.cli import main
    elif command == "tables":
        from icil_paper.book.tables_cli import main
    elif command == "reproduce":
        from icil_paper.reproduce import main
    elif command == "compare":
        from icil_paper.tables.compare import main
    elif command == "plan":
        from icil_paper.planning.decide import main
    elif command == "export-tokenizer":
        from icil_paper.interop.tokenizer_export import main
    else:
        raise KeyError(command)
    return main


def _env(argv: list[str]) -> int:
    parser = Parser(prog="icil-paper env",
                    description="Report packages, hardware, simulators and the preset.")
    parser.add_argument("--preset", choices=PRESET_NAMES, help="preset to report as active")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.add_argument("--no-sim", action="store_true", help="skip the simulator checks")
    args = parser.parse_args(argv)
    report = environment_report(active_preset_name(args.preset), simulators=not args.no_sim)
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0


def split_plugins(argv: list[str]) -> tuple[list[str], list[str]]:
    """(argv without them, the values of every `--plugin X` / `--plugin=X`)."""
    rest, specs = [], []
    args = iter(argv)
    for arg in args:
        if arg == "--plugin":
            value = next(args, None)
            if value is None or value.startswith("--"):
                raise ValueError("--plugin needs a module name or a .py file path")
            specs.append(value)
        elif arg.startswith("--plugin="):
            specs.append(arg.split("=", 1)[1])
        else:
            rest.append(arg)
    return rest, specs


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="icil-paper",
        description="Companion to 'Action Tokenizer Matters in In-Context Imitation Learning'. "
                    "Presets: smoke (seconds), small (CI, 2 CPU cores), reference (the "
                    f"committed run, seeds in stages within {REFERENCE_BUDGET_HOURS:g} hours on "
                    "2 cores), full (the paper's scale).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("env", help="report packages, hardware, simulators and the active preset",
                   add_help=False)
    parser.epilog = ("--debug anywhere on the command line shows a traceback instead of a "
                     "one-line error. --plugin MODULE_OR_FILE (repeatable) on any command "
                     "loads a module or .py file that registers tokenizers or policies "
                     "(icil_paper.plugins); installed packages' entry points of the groups "
                     "icil_paper.tokenizers and icil_paper.policies are loaded too.")
    for name, help_text in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def _dispatch(command: str, argv: list[str]) -> int | None:
    argv, plugin_specs = split_plugins(argv)
    if plugin_specs or command in SUBCOMMANDS:
        load_plugins(plugin_specs)  # entry points too: a bad plugin stops here, before work
    if command == "env":
        return _env(argv)
    if command not in SUBCOMMANDS:
        build_parser().error(f"unknown command {command!r}; valid commands: env, "
                             + ", ".join(SUBCOMMANDS))
    return command_main(command)(argv)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if a != "--debug"), "--help")
    if command in ("-h", "--help"):
        build_parser().print_help()
        return 0
    argv.remove(command)  # the rest, --debug included: run_module reads it
    try:
        return run_module(f"icil-paper {command}", partial(_dispatch, command), argv)
    except KeyboardInterrupt:
        print(f"icil-paper {command}: interrupted; rerun the same command to resume",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
