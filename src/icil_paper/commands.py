"""What every command of the command line shares: its parser, its arguments, its errors.

    from icil_paper.commands import Parser, add_preset_arguments, preset_from_args
    parser = Parser(prog="icil-paper train", description="...")
    add_preset_arguments(parser)                 # --preset, --seed, --set SECTION.FIELD=VALUE
    preset = preset_from_args(parser.parse_args(argv))

Each command is a module with a `main(argv)` that builds its parser from these; `run_module`
runs one with the command line's errors: a user error is one line naming the problem and the
fix, exit status 2 (`--debug` shows the traceback); other exceptions are bugs and show theirs.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from icil_paper.config import PRESET_NAMES, active_preset_name, get_preset


class RayUnavailable(RuntimeError):
    """Ray is not installed, or could not be started or reached (`tables.cells`)."""


USER_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError,
    RayUnavailable)
"""What a command reports in one line (exit 2) instead of a traceback."""


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
    """The preset named by --preset (or $ICIL_PRESET), with --seed and every --set applied."""
    if args.seed is not None and args.seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {args.seed}")
    preset = get_preset(active_preset_name(args.preset), seed=args.seed)
    return preset.with_overrides(args.overrides)


def add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    """--executor, --workers, --ray-address and --gpus-per-cell, for commands that run cells."""
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


def run_module(prog: str, command: Any, argv: list[str] | None = None) -> int:
    """`command(argv)` with the command line's errors: one of `USER_ERRORS` is one line and
    exit status 2 (`--debug` in argv shows the traceback)."""
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
    except BrokenPipeError:  # output piped into `head` and the like
        return 0
