"""Imports run one way: the import graph of `src/icil_paper`, drawn from the code with `ast`
(imports inside functions count), has no loop, and low-level packages import no higher one."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "icil_paper"


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
    assert "icil_paper.tables.execute" in graph["icil_paper.reproduce"]  # inside a function


def test_no_import_loop_between_files():
    found = cycles(import_graph())
    assert not found, "import loops (each a set of modules that import one another): " + \
        "; ".join(" <-> ".join(c) for c in found)


LOWER = {
    "icil_paper.tokenizers": ("icil_paper.config", "icil_paper.train", "icil_paper.eval",
                              "icil_paper.tables", "icil_paper.policies", "icil_paper.book.studies",
                              "icil_paper.data", "icil_paper.sim", "icil_paper.cli"),
    "icil_paper.policies.batching": ("icil_paper.policies",),
    "icil_paper.sim": ("icil_paper.data", "icil_paper.train", "icil_paper.eval",
                       "icil_paper.tables", "icil_paper.policies"),
    "icil_paper.train": ("icil_paper.eval", "icil_paper.tables", "icil_paper.book.studies",
                         "icil_paper.reproduce", "icil_paper.tables.grid"),
    "icil_paper.eval": ("icil_paper.tables", "icil_paper.book", "icil_paper.reproduce",
                        "icil_paper.tables.grid"),
    "icil_paper.data": ("icil_paper.book", "icil_paper.tables"),
    "icil_paper.viz": ("icil_paper.book",),
    "icil_paper.setup": ("icil_paper.book",),
    "icil_paper.tables": ("icil_paper.planning",),
    "icil_paper.bench": ("icil_paper.planning", "icil_paper.book"),
}
"""Package (or module) -> the higher ones it must not import."""


@pytest.mark.parametrize("low", sorted(LOWER))
def test_low_level_packages_import_no_higher_one(low):
    graph = import_graph()
    wrong = sorted(f"{m} -> {t}" for m, targets in graph.items()
                   if m == low or m.startswith(low + ".")
                   for t in targets
                   if any(t == h or t.startswith(h + ".") for h in LOWER[low]))
    assert not wrong, f"{low} imports a higher layer: {wrong}"


# --------------------------------------------------------------------------- the preset
PRESET_READERS = {"icil_paper.cli", "icil_paper.config"}
"""The only modules that may read the preset from the environment: the command line and
`config.py` (`active_preset_name`, `get_preset()`); the library takes it as an argument."""


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
    wrong = {name: lines for name, path in modules().items() if name not in PRESET_READERS
             and (lines := preset_reads(path.read_text()))}
    assert not wrong, f"the preset read from the environment outside the CLI and config.py " \
                      f"(pass it as an argument): {wrong}"
