"""The repository itself: nothing the library or the book needs may be left out of git."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _ignored(paths: list[str]) -> list[str]:
    out = subprocess.run(["git", "check-ignore", "--no-index", *paths], cwd=ROOT,
                         capture_output=True, text=True)
    return out.stdout.split()


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(),
                    reason="not a git checkout")
def test_no_source_file_is_ignored_by_git():
    sources = [str(p.relative_to(ROOT)) for folder in ("src", "tests", "notebooks", "book", "tools")
               for p in (ROOT / folder).rglob("*")
               if p.is_file() and p.suffix in (".py", ".md", ".yml")
               and not {"_build", "__pycache__", "node_modules"} & set(p.parts)]
    assert sources
    assert _ignored(sources) == []  # e.g. a `data/` pattern that also hides src/icil_paper/data


def test_code_passes_ruff():
    """`make lint`'s ruff as part of the suite, so that style drift fails CI (ruff is pinned;
    the import layers, `make lint`'s lint-imports, run in CI's own lint phase)."""
    ruff = Path(sys.executable).with_name("ruff")
    if not ruff.exists():
        pytest.skip("ruff is not installed beside this Python (make setup installs it)")
    out = subprocess.run([str(ruff), "check", "src", "tests", "notebooks", "book/_ext", "tools"],
                         cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def _layout_block() -> list[str]:
    text = (ROOT / "CONTRIBUTING.md").read_text()
    section = text.split("\n## Layout\n", 1)[1].split("\n## ", 1)[0]
    return section.split("```", 2)[1].strip("\n").splitlines()


def test_the_layout_section_is_true_to_the_tree():
    """CONTRIBUTING.md's layout names every module at the top of the library and every
    folder below it, and names nothing that does not exist."""
    import re

    lines = _layout_block()
    src = ROOT / "src" / "icil_paper"
    start = next(i for i, line in enumerate(lines) if line.startswith("src/icil_paper/"))
    end = next(i for i, line in enumerate(lines) if i > start and not line.startswith(" "))
    library = lines[start + 1:end]
    top = [line.split()[0].rstrip(",") for line in lines[:lines.index("")] if line[:1].strip()]
    for name in ",".join(top).split(","):  # "_toc.yml, _config.yml" names two files
        if name and not name.startswith("src/"):
            assert (ROOT / name.strip().rstrip("/")).exists(), f"layout names a missing {name}"
    listed = [line.split()[0] for line in library if re.match(r"  \S", line)]
    for name in listed:
        assert (src / name.rstrip(",/")).exists(), f"layout names a missing src/icil_paper/{name}"
    mentioned = set(re.findall(r"\b(\w+\.py)\b", "\n".join(library)))
    everywhere = {p.name for p in src.rglob("*.py")}
    assert mentioned <= everywhere, f"layout names missing modules: {mentioned - everywhere}"
    modules = sorted(p.name for p in src.glob("*.py") if p.name != "__init__.py")
    packages = sorted(f"{p.name}/" for p in src.iterdir()
                      if p.is_dir() and (p / "__init__.py").exists())
    assert not set(modules) - mentioned, f"modules the layout omits: {set(modules) - mentioned}"
    assert not set(packages) - set(listed), f"folders the layout omits: {set(packages) - set(listed)}"
    count = int(re.search(r"(\d+) modules at the top", lines[start]).group(1))
    assert count == len(modules), f"the layout says {count} modules at the top, there are {len(modules)}"


def test_the_layout_names_every_tool():
    """The layout's tools/ entry names every module and folder of tools/, and no module that
    is not there."""
    import re

    lines = _layout_block()
    start = next(i for i, line in enumerate(lines) if line.startswith("tools/"))
    end = next((i for i, line in enumerate(lines) if i > start and not line.startswith(" ")),
               len(lines))
    text = "\n".join(lines[start:end])
    tools = ROOT / "tools"
    modules = {p.name for p in tools.glob("*.py") if p.name != "__init__.py"}
    folders = {p.name for p in tools.iterdir() if (p / "__init__.py").exists()}
    named = set(re.findall(r"\b(\w+\.py)\b", text))
    assert named == modules, f"tools/ holds {sorted(modules)}, the layout names {sorted(named)}"
    missing = {f for f in folders if f"{f}/" not in text}
    assert not missing, f"folders of tools/ the layout omits: {sorted(missing)}"


def _documented_benchmarks() -> list[str]:
    """The benchmarks CONTRIBUTING.md's Benchmarks section says `make bench` runs: the
    backticked names of its first paragraph."""
    import re

    section = (ROOT / "CONTRIBUTING.md").read_text().split("\n## Benchmarks\n", 1)[1]
    paragraph = section.strip().split("\n\n", 1)[0]
    assert paragraph.startswith("`make bench` runs"), paragraph[:80]
    return re.findall(r"`(\w+)`", paragraph.split("Each writes", 1)[0])


def _make_benchmarks() -> list[str]:
    import re

    found = re.search(r"^BENCHMARKS := (.+)$", (ROOT / "Makefile").read_text(), re.MULTILINE)
    assert found, "the Makefile names no BENCHMARKS"
    return found.group(1).split()


def test_make_bench_runs_exactly_the_documented_benchmarks():
    """`make bench` runs the benchmarks CONTRIBUTING.md lists, each a module of tools/bench/,
    and tools/bench/ holds nothing else (the pilots are tools/pilot.py, the README's figures
    tools/readme_figures.py)."""
    documented, made = _documented_benchmarks(), _make_benchmarks()
    assert documented, "CONTRIBUTING.md's Benchmarks section lists no benchmark"
    assert sorted(made) == sorted(documented), \
        f"make bench runs {made}, CONTRIBUTING.md lists {documented}"
    modules = sorted(p.stem for p in (ROOT / "tools" / "bench").glob("*.py")
                     if p.name != "__init__.py")
    assert sorted(documented) == modules, f"tools/bench/ holds {modules}, documented: {documented}"
    assert "\npilot: " in (ROOT / "Makefile").read_text()  # the pilot runs on its own


def test_the_readme_reads_in_five_minutes():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 150
    for heading in ("## Two commands", "## What you get", "## Presets", "## On a cluster",
                    "## Where to go next"):
        assert heading in readme
    assert "CONTRIBUTING.md" in readme


MODULE_DOCSTRING_LINES = 25
"""A module docstring says what the module is and how to use it; history and findings live
in git, the book and CONTRIBUTING.md."""

def _module_docstring_lines(path: Path) -> int:
    """Lines the module docstring spans in the file, quotes included (0 without one)."""
    body = ast.parse(path.read_text(encoding="utf-8")).body
    if not (body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)):
        return 0
    return body[0].end_lineno - body[0].lineno + 1


def test_module_docstrings_are_short():
    too_long = {}
    for path in sorted((ROOT / "src" / "icil_paper").rglob("*.py")):
        name = path.relative_to(ROOT).as_posix()
        lines = _module_docstring_lines(path)
        if lines > MODULE_DOCSTRING_LINES:
            too_long[name] = lines
    assert not too_long, (f"module docstrings over {MODULE_DOCSTRING_LINES} lines (say what the "
                          f"module is and how to use it; history goes to git): {too_long}")
