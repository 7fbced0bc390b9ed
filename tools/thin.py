"""The thin library's targets, measured: lines, docstrings, imports by name, CONTRIBUTING,
cell cost, and (with --chain) the modules between a table's cell and `loss.backward()`.

    python -m tools.thin            # the cheap counts, a line each; exit 1 when one is missed
    python -m tools.thin --chain    # also trace Table I's smoke cell to loss.backward (minutes)

The cell cost is read from `results/bench/cells.json` (`python -m tools.bench.cells`
measures it); `make test`'s time is the test run's own.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import json
import os
import re
import sys
import tempfile
from pathlib import Path

from icil_paper.config import get_preset
from icil_paper.paper import run_tables

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "icil_paper"
TARGETS = {"lines": 22_000, "module_docstring_lines": 25, "contributing_lines": 250,
           "chain_modules": 8, "floor_ratio": 1.25}
"""The issue's targets: at most these."""
IMPORT_BY_NAME_ALLOWED = {"plugins.py"}
"""The modules that may import a module named by a string (plugins load by entry point)."""


def package_lines() -> int:
    return sum(len(p.read_text().splitlines()) for p in PACKAGE.rglob("*.py"))


def longest_module_docstring() -> tuple[int, str]:
    """(lines, module) of the longest module docstring of the package."""
    longest = (0, "")
    for path in PACKAGE.rglob("*.py"):
        doc = ast.get_docstring(ast.parse(path.read_text()), clean=False) or ""
        longest = max(longest, (len(doc.splitlines()), str(path.relative_to(PACKAGE))))
    return longest


def imports_by_name() -> list[str]:
    """Modules outside `IMPORT_BY_NAME_ALLOWED` that call `import_module`."""
    return sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                  if p.name not in IMPORT_BY_NAME_ALLOWED
                  and re.search(r"\bimport_module\(", p.read_text()))


def floor_ratios() -> dict[str, float]:
    return json.loads((ROOT / "results" / "bench" / "cells.json").read_text())["floor_ratio"]


def chain_modules() -> list[str]:
    """The package's modules on the stack when Table I's first smoke cell, run serially in
    this process, first calls `loss.backward()` (outermost first, each once). Results and
    runs go to a temporary folder, so that nothing stored is found instead."""
    import torch

    seen: list[str] = []
    backward = torch.Tensor.backward

    def traced(self, *args, **kwargs):
        if not seen:
            frame = sys._getframe(1)
            stack = []
            while frame is not None:
                name = frame.f_globals.get("__name__", "")
                if name.startswith("icil_paper") and name not in stack:
                    stack.append(name)
                frame = frame.f_back
            seen.extend(reversed(stack))
            raise StopIteration  # one step is all it takes
        return backward(self, *args, **kwargs)

    torch.Tensor.backward = traced
    with tempfile.TemporaryDirectory() as scratch:
        os.environ.update(ICIL_RESULTS=f"{scratch}/results", ICIL_RUNS=f"{scratch}/runs")
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # the runner's "failed" line
                run_tables(get_preset("smoke"), ["I"], executor="serial", progress=False)
        except Exception:  # the stop above, as the runner reports a failed cell
            if not seen:
                raise
        finally:
            torch.Tensor.backward = backward
    return seen


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chain", action="store_true",
                        help="also trace a smoke cell to loss.backward (trains a policy)")
    args = parser.parse_args()
    doc_lines, doc_module = longest_module_docstring()
    contributing = len((ROOT / "CONTRIBUTING.md").read_text().splitlines())
    ratios = floor_ratios()
    rows = [("lines in src/icil_paper", package_lines(), TARGETS["lines"]),
            (f"longest module docstring ({doc_module})", doc_lines,
             TARGETS["module_docstring_lines"]),
            ("modules importing by name outside plugins.py", len(imports_by_name()), 0),
            ("lines of CONTRIBUTING.md", contributing, TARGETS["contributing_lines"])]
    rows += [(f"cell cost over its floor: {kind}", ratio, TARGETS["floor_ratio"])
             for kind, ratio in sorted(ratios.items())]
    if args.chain:
        chain = chain_modules()
        print("chain:", " -> ".join(chain))
        rows.append(("modules from a table's cell to loss.backward", len(chain),
                     TARGETS["chain_modules"]))
    missed = 0
    for what, value, target in rows:
        ok = value <= target
        missed += not ok
        print(f"{'ok  ' if ok else 'MISS'} {what}: {value} (target at most {target})")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
