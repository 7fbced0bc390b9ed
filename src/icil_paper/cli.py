"""`icil-paper`: the command line of the companion.

Each subcommand is a module-level `main(argv)` imported only when used, so `--help` is fast
and one broken part of the library does not take the others down. Every command that takes
a preset also takes `--seed` and `--set SECTION.FIELD=VALUE` (repeatable), typed and
checked against the config dataclasses (`icil_paper.commands`, which every command's
module builds its parser from: this module sits on top and no other imports it).

A user error (an unknown name, a bad value, a missing or damaged file) ends the command
with one line naming the problem and the fix, and exit status 2; `--debug` (anywhere on the
command line) shows the traceback instead. Other exceptions are bugs and show theirs.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

from icil_paper import commands
from icil_paper.commands import Parser, RayUnavailable
from icil_paper.config import PRESET_NAMES, REFERENCE_BUDGET_HOURS, active_preset_name
from icil_paper.plugins import load_plugins
from icil_paper.setup.envcheck import environment_report, format_report

USER_ERRORS: tuple[type[BaseException], ...] = (*commands.USER_ERRORS, RayUnavailable)
"""What a command reports in one line (exit 2) instead of a traceback: the commands' own
(`commands.USER_ERRORS`) and RayUnavailable, which says why Ray could not be imported,
started or reached."""

# subcommand -> (module with main(argv), one-line help)
SUBCOMMANDS = {
    "demos": ("icil_paper.data.cli", "generate demonstration data sets (robomimic HDF5)"),
    "train": ("icil_paper.train.cli", "train a policy (ICRT or a baseline) with a tokenizer"),
    "eval": ("icil_paper.eval.cli", "roll out a trained policy and store its success rate"),
    "tables": ("icil_paper.book.tables_cli", "print the paper's tables and claims from the results store"),
    "reproduce": ("icil_paper.reproduce", "run every experiment of a preset (then `make book`)"),
    "compare": ("icil_paper.tables.compare",
                "a tokenizer against LipVQ-VAE on Table I's protocol: difference, verdict, power"),
    "plan": ("icil_paper.planning.decide", "the seeds, cells and CPU-hours that would decide every "
             "undecided claim, and the run that computes them"),
    "export-tokenizer": ("icil_paper.interop.tokenizer_export",
                         "write a trained policy's tokenizer as a portable folder (safetensors)"),
}


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
    i = 0
    while i < len(argv):
        arg = argv[i]
        if arg == "--plugin":
            if i + 1 >= len(argv) or argv[i + 1].startswith("--"):
                raise ValueError("--plugin needs a module name or a .py file path")
            specs.append(argv[i + 1])
            i += 2
            continue
        if arg.startswith("--plugin="):
            specs.append(arg.split("=", 1)[1])
        else:
            rest.append(arg)
        i += 1
    return rest, specs


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="icil-paper",
        description="Companion to 'Action Tokenizer Matters in In-Context Imitation Learning'. "
                    "Presets: smoke (seconds), small (CI, 2 CPU cores), reference (the "
                    f"committed run, seeds in stages within {REFERENCE_BUDGET_HOURS:g} hours on "
                    "2 cores), full (the "
                    "paper's scale).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("env", help="report packages, hardware, simulators and the active preset",
                   add_help=False)
    parser.epilog = ("--debug anywhere on the command line shows a traceback instead of a "
                     "one-line error. --plugin MODULE_OR_FILE (repeatable) on any command "
                     "loads a module or .py file that registers tokenizers or policies "
                     "(icil_paper.plugins); installed packages' entry points of the groups "
                     "icil_paper.tokenizers and icil_paper.policies are loaded too.")
    for name, (_, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    parser = build_parser()
    if not argv or argv[0] in ("-h", "--help"):
        parser.print_help()
        return 0
    command, rest = argv[0], argv[1:]
    try:
        rest, plugin_specs = split_plugins(rest)
        if plugin_specs or command in SUBCOMMANDS:
            load_plugins(plugin_specs)  # entry points too: a bad plugin stops here, before work
        if command == "env":
            return _env(rest)
        if command not in SUBCOMMANDS:
            parser.error(f"unknown command {command!r}; valid commands: env, "
                         + ", ".join(SUBCOMMANDS))
        module = importlib.import_module(SUBCOMMANDS[command][0])
        return int(module.main(rest) or 0)
    except USER_ERRORS as exc:
        if debug:
            raise
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"icil-paper {command}: error: {message} (--debug shows the traceback)",
              file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and the like
        return 0
    except KeyboardInterrupt:
        print(f"icil-paper {command}: interrupted; rerun the same command to resume",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
