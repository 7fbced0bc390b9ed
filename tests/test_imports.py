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
                              "icil_paper.tables", "icil_paper.policies", "icil_paper.studies",
                              "icil_paper.data", "icil_paper.sim", "icil_paper.cli"),
    "icil_paper.policies.batching": ("icil_paper.policies",),
    "icil_paper.sim": ("icil_paper.data", "icil_paper.train", "icil_paper.eval",
                       "icil_paper.tables", "icil_paper.policies"),
    "icil_paper.train": ("icil_paper.eval", "icil_paper.tables", "icil_paper.studies",
                         "icil_paper.reproduce", "icil_paper.grid"),
    "icil_paper.eval": ("icil_paper.tables", "icil_paper.studies", "icil_paper.reproduce",
                        "icil_paper.grid"),
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
