"""`icil-paper`: the command line of the companion.

Each subcommand is a module-level `main(argv)` imported only when used, so `--help` is fast
and one broken part of the library does not take the others down.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

from icil_paper.config import PRESET_NAMES
from icil_paper.registry import UnknownNameError

# subcommand -> (module with main(argv), one-line help)
SUBCOMMANDS = {
    "demos": ("icil_paper.data.cli", "generate demonstration data sets (robomimic HDF5)"),
    "train": ("icil_paper.train", "train a policy (ICRT or a baseline) with a tokenizer"),
    "eval": ("icil_paper.evaluate", "roll out a trained policy and store its success rate"),
    "tables": ("icil_paper.tables", "compute the paper's tables from the results store"),
    "reproduce": ("icil_paper.reproduce", "run every experiment of a preset (then `make book`)"),
}


def _env(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="icil-paper env",
                                     description="Report packages, hardware, simulators and the preset.")
    parser.add_argument("--preset", choices=PRESET_NAMES, help="preset to report as active")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.add_argument("--no-sim", action="store_true", help="skip the simulator checks")
    args = parser.parse_args(argv)
    if args.preset:
        import os

        os.environ["ICIL_PRESET"] = args.preset
    from icil_paper.envcheck import environment_report, format_report

    report = environment_report(simulators=not args.no_sim)
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="icil-paper",
        description="Companion to 'Action Tokenizer Matters in In-Context Imitation Learning'. "
                    "Presets: smoke (seconds), small (CI, 2 CPU cores), full (the paper's scale).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("env", help="report packages, hardware, simulators and the active preset",
                   add_help=False)
    for name, (_, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0] in ("-h", "--help"):
        parser.print_help()
        return 0
    command, rest = argv[0], argv[1:]
    try:
        if command == "env":
            return _env(rest)
        if command not in SUBCOMMANDS:
            parser.error(f"unknown command {command!r}; valid commands: env, "
                         + ", ".join(SUBCOMMANDS))
        module_name = SUBCOMMANDS[command][0]
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name and module_name.startswith(exc.name):
                print(f"icil-paper {command}: not available yet ({module_name} is not part "
                      "of this version; the README's 'What is reproduced so far' lists what "
                      "is)", file=sys.stderr)
                return 2
            raise
        return int(module.main(rest) or 0)
    except UnknownNameError as exc:
        print(f"icil-paper {command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
