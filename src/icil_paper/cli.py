"""`icil-paper`: the command line of the companion.

Each subcommand is a module-level `main(argv)` imported only when used, so `--help` is fast
and one broken part of the library does not take the others down. Every command that takes
a preset also takes `--seed` and `--set SECTION.FIELD=VALUE` (repeatable), typed and
checked against the config dataclasses (`add_preset_arguments`, `preset_from_args`).

A user error (an unknown name, a bad value, a missing or damaged file) ends the command
with one line naming the problem and the fix, and exit status 2; `--debug` (anywhere on the
command line) shows the traceback instead. Other exceptions are bugs and show theirs.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from typing import Any

from icil_paper.config import PRESET_NAMES
from icil_paper.plugins import load_plugins
from icil_paper.tables.grid import RayUnavailable

USER_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError,
    RayUnavailable)
"""What a command reports in one line (exit 2) instead of a traceback. ValueError covers
UnknownNameError, OverrideError, ConfigError, DatasetError, RunFolderError,
UnreadableFileError (PolicyFileError among them), TokenizerFolderError, PluginError and
json.JSONDecodeError, whose messages name the problem; PermissionError covers
FolderNotWritableError (an output folder refused before any work); RayUnavailable says why
Ray could not be imported, started or reached."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: the problem and where to look, not the whole usage."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (--help lists the options)\n")


def add_preset_arguments(parser: argparse.ArgumentParser) -> None:
    """--preset, --seed and --set, shared by every command that takes a preset."""
    parser.add_argument("--preset", choices=PRESET_NAMES, default=None,
                        help="preset (default: $ICIL_PRESET or small)")
    parser.add_argument("--seed", type=int, default=None, help="override the preset's seed")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="SECTION.FIELD=VALUE",
                        help="change one field of the preset, typed and checked (repeatable), "
                             "e.g. --set train.steps=300 --set tokenizers.lipvq.codebook_size=512")


def preset_from_args(args: argparse.Namespace) -> Any:
    """The preset named by --preset (or $ICIL_PRESET), with --seed and every --set applied;
    every config checks its values as it is built (its `__post_init__`), so before any
    work. (A command that runs the preset's task lists checks them: `config.check_tasks`.)"""
    from icil_paper.config import active_preset_name, get_preset

    if args.seed is not None and args.seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {args.seed}")
    preset = get_preset(active_preset_name(args.preset), seed=args.seed)
    return preset.with_overrides(args.overrides)


def add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    """--executor, --workers, --ray-address and --gpus-per-cell, shared by every command that
    runs table cells (`reproduce`, `compare`); `check_executor_arguments` checks them."""
    parser.add_argument("--executor", choices=("local", "ray", "serial"), default="local",
                        help="how the cells run: a local process pool (default), a Ray "
                             "cluster, or one after the other in this process")
    parser.add_argument("--workers", type=positive("--workers"), default=None,
                        help="parallel cells (default: the preset's eval.workers)")
    parser.add_argument("--ray-address", default=None, metavar="HOST:PORT",
                        help="with --executor ray: join this cluster (default: start one here)")
    parser.add_argument("--gpus-per-cell", type=float, default=0.0, metavar="N",
                        help="with --executor ray: GPUs each cell asks for (e.g. 1 on GPU "
                             "nodes; its training and rollouts then run on that GPU)")


def check_executor_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, through `parser.error`, executor arguments that do not go together."""
    if not 0 <= args.gpus_per_cell <= 64:
        parser.error(f"--gpus-per-cell must be between 0 and 64, got {args.gpus_per_cell}")
    if args.ray_address is not None:
        if not args.ray_address.strip():
            parser.error("--ray-address is empty: give the Ray head as HOST:PORT (e.g. "
                         "--ray-address 127.0.0.1:6379) or `auto`, or leave it out to start a "
                         "local Ray")
        if args.executor != "ray":
            parser.error(f"--ray-address {args.ray_address} is for --executor ray (this run's "
                         f"executor is {args.executor}): add --executor ray to run the cells "
                         "on that cluster, or leave --ray-address out")


def positive(name: str):
    """An argparse type: an integer >= 1, refused before any work with a message naming it."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer, got {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{name} must be at least 1, got {value}")
        return value
    return parse

# subcommand -> (module with main(argv), one-line help)
SUBCOMMANDS = {
    "demos": ("icil_paper.data.cli", "generate demonstration data sets (robomimic HDF5)"),
    "train": ("icil_paper.train.cli", "train a policy (ICRT or a baseline) with a tokenizer"),
    "eval": ("icil_paper.eval.cli", "roll out a trained policy and store its success rate"),
    "tables": ("icil_paper.tables.cli", "print the paper's tables and claims from the results store"),
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
    from icil_paper.config import active_preset_name
    from icil_paper.setup.envcheck import environment_report, format_report

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
                    "Presets: smoke (seconds), small (CI, 2 CPU cores), full (the paper's scale).",
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


def run_module(prog: str, command: Any, argv: list[str] | None = None) -> int:
    """`command(argv)` (a module's `main`, run as `python -m ...`) with the errors of the
    command line: a user error is one line naming the problem and the fix and exit status
    2 (`--debug` shows the traceback), as for `icil-paper` itself."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    try:
        return int(command([a for a in argv if a != "--debug"]) or 0)
    except USER_ERRORS as exc:
        if debug:
            raise
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"{prog}: error: {message} (--debug shows the traceback)", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
