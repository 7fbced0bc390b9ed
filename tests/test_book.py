"""The book's configuration: every chapter exists and is listed, and a failing cell fails the build."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]


def _toc_files():
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    files = [toc["root"]]
    for part in toc.get("parts", []):
        files += [chapter["file"] for chapter in part["chapters"]]
    return files


def test_every_toc_entry_exists_and_every_notebook_is_listed():
    listed = _toc_files()
    for entry in listed:
        assert any((ROOT / f"{entry}{ext}").exists() for ext in (".md", ".py", ".ipynb")), entry
    notebooks = sorted(f"notebooks/{p.stem}" for p in (ROOT / "notebooks").glob("[0-9]*.py"))
    assert notebooks, "no chapters"
    assert [n for n in notebooks if n not in listed] == []
    assert listed[1:] == sorted(listed[1:]), "chapters are listed in their numbered order"


def test_config_makes_failing_cells_fail_the_build():
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    assert config["only_build_toc_files"] is True
    assert config["sphinx"]["config"]["nb_execution_raise_on_error"] is True
    assert "book/_build" in config["exclude_patterns"]


@pytest.mark.slow
def test_book_build_fails_on_a_failing_cell(tmp_path):
    jupyter_book = Path(sys.executable).with_name("jupyter-book")
    if not jupyter_book.exists():
        pytest.skip("jupyter-book is not installed in this environment")
    shutil.copy(ROOT / "_config.yml", tmp_path / "_config.yml")
    (tmp_path / "_toc.yml").write_text(
        "format: jb-book\nroot: intro\nchapters:\n  - file: notebooks/bad\n")
    (tmp_path / "intro.md").write_text("# Intro\n")
    (tmp_path / "notebooks").mkdir()
    (tmp_path / "notebooks" / "bad.py").write_text(
        '# %%\nprint("fine")\n\n# %%\nraise RuntimeError("this cell fails")\n')
    out = subprocess.run([str(jupyter_book), "build", ".", "--path-output", "book"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert out.returncode != 0, "a failing cell must fail the book build"
    assert "CellExecutionError" in out.stdout + out.stderr
