"""Imports run one way and sit at the top of the file.

The layers of the package are stated once, as import-linter contracts in pyproject.toml
(`[tool.importlinter]`), and checked by `make lint`. Here: the import graph of
`src/icil_paper`, drawn from the code with `ast` (imports inside functions count), has no
loop between files and no import of the project's `tools/`; an import inside a function (or
any block; in `tools/` too) is for a heavy optional dependency only (`HEAVY`), so that the
file graph shows the real layers; and the presets, the command line and the list of task
suites load without torch or a simulator.
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "icil_paper"
TOOLS = SRC.parent / "tools"
"""The project's tools (benchmarks, checks, setup): held to the same import habits."""


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _target(name: str, known: dict[str, Path]) -> str | None:
    """The file (module name) an imported dotted name lives in."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def import_graph() -> dict[str, set[str]]:
    """module -> the modules of this package it imports (anywhere in the file, at any
    depth: a function's own import counts). `from a.b import c` goes to `a.b.c` where that
    is a module, else to `a.b`; a package's `__init__` is an edge only where it is named."""
    known = modules()
    graph: dict[str, set[str]] = {}
    for name, path in known.items():
        edges: set[str] = set()
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")
                    up = up[:len(up) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                           for a in node.names]
            else:
                continue
            for t in targets:
                if t.startswith("icil_paper"):
                    found = _target(t, known)
                    if found and found != name:
                        edges.add(found)
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_finds_a_loop_when_there_is_one():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
    graph = import_graph()
    assert "icil_paper.config" in graph["icil_paper.runspec"]  # a top-level import
    assert "icil_paper.paper" in graph["icil_paper.reproduce"]


def test_no_import_loop_between_files():
    found = cycles(import_graph())
    assert not found, "import loops (each a set of modules that import one another): " + \
        "; ".join(" <-> ".join(c) for c in found)


# --------------------------------------------------------------------------- no tools
def tool_imports(source: str) -> list[tuple[int, str]]:
    """(line, module) of every import of `tools` (the project's benchmarks, checks and setup,
    in the repository's `tools/`) in `source`, at any depth."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names = [node.module or ""]
        else:
            continue
        found += [(node.lineno, n) for n in names if n.split(".")[0] == "tools"]
    return found


def test_tool_imports_are_found():
    source = ("import tools.bench.cells\nfrom tools import browser_check\n"
              "def f():\n    from tools.system_deps import find_chromium\n"
              "import toolsmith\nfrom icil_paper import tools_of\n")
    assert tool_imports(source) == [(1, "tools.bench.cells"), (2, "tools"),
                                    (4, "tools.system_deps")]


def test_the_library_imports_no_tool():
    """The tools import the library, never the other way: what a user imports of
    `icil_paper` must not need the repository's `tools/`."""
    wrong = [f"{path.relative_to(SRC.parent)}:{line}: {name}"
             for path in modules().values() for line, name in tool_imports(path.read_text())]
    assert not wrong, "the library imports tools/: " + "; ".join(wrong)


# --------------------------------------------------------------------------- imports at the top
HEAVY = frozenset({
    "torch", "torchvision", "vector_quantize_pytorch", "safetensors",  # torch and its kin
    "robosuite", "mujoco", "mani_skill", "sapien", "gymnasium", "robomimic",  # simulators
    "rerun", "ray", "matplotlib", "pandas", "scipy", "sklearn", "h5py",
    "IPython", "playwright", "tokenizers", "lerobot",
})
"""The third-party packages that may be imported inside a function: heavy to import (torch
alone takes a second), or optional (a simulator, Ray, rerun, LeRobot's own environment).
Every other import, and every import of this package, sits at the top of its file, but for
the explicit imports of `LAZY`."""

LAZY = {
    "__getattr__": "a package's `__init__` imports its own torch-backed modules on first use of "
                   "their names (PEP 562): `from icil_paper.tokenizers import make_tokenizer` "
                   "works while importing the package (and its torch-free configs) loads no torch",
    "command_main": "the command line imports a subcommand's module when it runs "
                    "(`icil_paper.cli`), so that `icil-paper --help` is fast",
}
"""Module-level functions whose imports of this package load heavy modules on use; the
import graph still counts those edges."""


def nested_imports(source: str, package: str | None = None) -> list[tuple[int, str]]:
    """(line, statement) of every import in `source` that is not at the top of the file (in a
    function, a class, or a block such as `if __name__ == "__main__":`) and imports something
    other than a `HEAVY` package. Imports under `if TYPE_CHECKING:` run only for type
    checkers and count as the top of the file. `package`: where `source` is a package's
    `__init__`, its module-level `__getattr__` may import that package's modules; anywhere, a
    module-level `command_main` may import this package's (`LAZY`)."""
    found: list[tuple[int, str]] = []

    def lazy_ok(node: ast.Import | ast.ImportFrom, function: str | None) -> bool:
        if not isinstance(node, ast.ImportFrom) or node.level or not node.module:
            return False
        if function == "__getattr__":
            return package is not None and node.module == package
        return function == "command_main" and node.module.startswith("icil_paper.")

    def light(node: ast.Import | ast.ImportFrom) -> bool:
        if isinstance(node, ast.ImportFrom):
            return node.level > 0 or (node.module or "").split(".")[0] not in HEAVY
        return any(a.name.split(".")[0] not in HEAVY for a in node.names)

    def visit(node: ast.AST, top: bool, function: str | None = None) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                if not top and light(child) and not lazy_ok(child, function):
                    found.append((child.lineno, ast.unparse(child)))
                continue
            if top:  # a module-level function of LAZY, or none
                function = child.name if isinstance(child, ast.FunctionDef) \
                    and child.name in LAZY else None
            visit(child, top=False, function=function)

    visit(ast.parse(source), top=True)
    return found


def test_nested_imports_are_found():
    source = (
        "import json\n"
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from icil_paper.config import Preset\n"
        "def f():\n"
        "    import torch\n"
        "    from scipy.stats import t\n"
        "    from icil_paper.sim import make_env\n"
        "    import math\n"
        "    return torch, t, make_env, math\n"
        "class C:\n"
        "    def g(self):\n"
        "        from . import sibling\n"
        "if __name__ == '__main__':\n"
        "    from icil_paper.commands import run_module\n")
    assert nested_imports(source) == [
        (8, "from icil_paper.sim import make_env"), (9, "import math"),
        (13, "from . import sibling"), (15, "from icil_paper.commands import run_module")]
    assert nested_imports("import torch\nfrom icil_paper import sim\n") == []
    lazy = ("def __getattr__(name):\n    from icil_paper.tokenizers import base\n"
            "    from icil_paper.sim import make_env\n"
            "def f():\n    from icil_paper.tokenizers import base\n")
    assert nested_imports(lazy, "icil_paper.tokenizers") == [
        (3, "from icil_paper.sim import make_env"), (5, "from icil_paper.tokenizers import base")]
    assert len(nested_imports(lazy)) == 3  # only a package's own __init__ may
    dispatch = ("def command_main(c):\n    if c == 'a':\n        from icil_paper.x import main\n"
                "    return main\ndef other():\n    from icil_paper.y import main\n")
    assert nested_imports(dispatch) == [(6, "from icil_paper.y import main")]


def test_imports_inside_functions_are_heavy_dependencies_only():
    wrong = [f"{path.relative_to(SRC.parent)}:{line}: {statement}"
             for name, path in [*modules().items(),
                                *((None, p) for p in sorted(TOOLS.rglob("*.py")))]
             for line, statement in nested_imports(
                 path.read_text(), name if path.name == "__init__.py" else None)]
    assert not wrong, ("imports inside functions that belong at the top of the file (only "
                       "the heavy packages of HEAVY may be imported on use): "
                       + "; ".join(wrong))


LIGHT = {
    "icil_paper.cli": HEAVY | {"numpy"},
    "icil_paper.config": HEAVY | {"numpy"},
    "icil_paper.runspec": HEAVY,
    "icil_paper.records": HEAVY,
    "icil_paper.tokenizers": HEAVY,
    "icil_paper.policies": HEAVY,
    "icil_paper.sim": HEAVY - {"gymnasium"},
}
"""Module -> the packages importing it must not import: the command line (`icil-paper
--help`), the presets and run specs (which a notebook's config cell or a grid worker's
parent reads) and the component packages' configs load without torch; listing the task
suites (`icil_paper.sim`) imports no simulator (gymnasium's registry is where it lists
them)."""


@pytest.mark.parametrize("module", sorted(LIGHT))
def test_light_modules_load_without_heavy_packages(module):
    code = (f"import sys, json; import {module}; "
            f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
            f"{sorted(LIGHT[module])!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={**os.environ, "PYTHONPATH": str(SRC)})
    loaded = {m.split(".")[0] for m in json.loads(out.stdout.strip().splitlines()[-1])}
    assert not loaded, f"importing {module} imports {sorted(loaded)}"


# --------------------------------------------------------------------------- the preset
PRESET_READERS = {"icil_paper.cli", "icil_paper.commands", "icil_paper.config"}
"""The only modules that may read the preset from the environment: the command line (`cli.py`
and the arguments every command shares, `commands.py`) and `config.py` (`active_preset_name`,
`get_preset()`); the library takes it as an argument."""


def preset_reads(source: str) -> list[int]:
    """Lines of `source` that read $ICIL_PRESET: `os.environ[...]`, `os.environ.get(...)`
    or `os.getenv(...)` of "ICIL_PRESET" or `PRESET_ENV_VAR`, a call of
    `active_preset_name`, or `get_preset()` without a name."""

    def names_the_variable(node: ast.AST) -> bool:
        return ((isinstance(node, ast.Constant) and node.value == "ICIL_PRESET")
                or (isinstance(node, (ast.Name, ast.Attribute))
                    and getattr(node, "id", getattr(node, "attr", None)) == "PRESET_ENV_VAR"))

    def callee(node: ast.Call) -> str:
        f = node.func
        return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""

    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Subscript) and ast.unparse(node.value).endswith("environ") \
                and names_the_variable(node.slice):
            lines.append(node.lineno)
        elif isinstance(node, ast.Call):
            name = callee(node)
            if name in ("get", "getenv", "pop", "setdefault") and node.args \
                    and names_the_variable(node.args[0]) and "environ" in ast.unparse(node.func) \
                    or name == "getenv" and node.args and names_the_variable(node.args[0]):
                lines.append(node.lineno)
            elif name == "active_preset_name":
                lines.append(node.lineno)
            elif name == "get_preset" and not node.args and not any(
                    k.arg == "name" for k in node.keywords):
                lines.append(node.lineno)
    return sorted(set(lines))


def test_preset_reads_are_found():
    assert preset_reads("import os\nx = os.environ.get('ICIL_PRESET')\n") == [2]
    assert preset_reads("x = os.environ[PRESET_ENV_VAR]\ny = os.getenv('ICIL_PRESET')") == [1, 2]
    assert preset_reads("a = active_preset_name(None)\nb = get_preset()\nc = get_preset('s')") == [1, 2]
    assert preset_reads("msg = 'set ICIL_PRESET'\nd = os.environ.get('ICIL_DATA')") == []


def test_only_the_cli_and_config_read_the_preset_from_the_environment():
    tools = {str(p.relative_to(SRC.parent)): p for p in sorted(TOOLS.rglob("*.py"))}
    wrong = {name: lines for name, path in {**modules(), **tools}.items()
             if name not in PRESET_READERS and (lines := preset_reads(path.read_text()))}
    assert not wrong, f"the preset read from the environment outside the command line and " \
                      f"config.py (pass it as an argument): {wrong}"


# --------------------------------------------------------------------------- no string imports
IMPORTS_BY_NAME = {
    "icil_paper/plugins.py",  # plugins: a module or file named by the user, entry points
    "icil_paper/tables/grid.py", "icil_paper/reproduce.py", "icil_paper/eval/rollouts.py",
}
"""The files that still import a module named by a string; plugin loading is the one place
meant to keep it (a debugger does not follow an import by name)."""


def test_modules_are_imported_by_name_only_where_listed():
    wrong = [str(path.relative_to(SRC)) for path in modules().values()
             if "import_module(" in path.read_text()
             and str(path.relative_to(SRC)) not in IMPORTS_BY_NAME]
    assert not wrong, f"importlib.import_module by name outside plugin loading: {wrong}"
