"""The repository itself: nothing the library or the book needs may be left out of git."""

from __future__ import annotations

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
    sources = [str(p.relative_to(ROOT)) for folder in ("src", "tests", "notebooks", "book")
               for p in (ROOT / folder).rglob("*")
               if p.is_file() and p.suffix in (".py", ".md", ".yml")
               and not {"_build", "__pycache__", "node_modules"} & set(p.parts)]
    assert sources
    assert _ignored(sources) == []  # e.g. a `data/` pattern that also hides src/icil_paper/data


def test_code_passes_ruff():
    """`make lint` as part of the suite, so that style drift fails CI (ruff is pinned)."""
    ruff = Path(sys.executable).with_name("ruff")
    if not ruff.exists():
        pytest.skip("ruff is not installed beside this Python (make setup installs it)")
    out = subprocess.run([str(ruff), "check", "src", "tests", "notebooks", "book/_ext"], cwd=ROOT,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
