"""The book's configuration: every chapter exists and is listed, a failing cell fails the
build, the browser assets are local and pinned, and chapters stage their recordings."""

import base64
import html as html_lib
import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from icil_paper.viz import viewer

ROOT = Path(__file__).resolve().parents[1]


def load_book_assets():
    """The book's local Sphinx extension (book/_ext/book_assets.py), imported by path."""
    spec = importlib.util.spec_from_file_location("book_assets",
                                                  ROOT / "book" / "_ext" / "book_assets.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


book_assets = load_book_assets()


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
    if book_assets.installed_problem():
        pytest.skip(f"{book_assets.installed_problem()} (run `make setup`)")
    shutil.copy(ROOT / "_config.yml", tmp_path / "_config.yml")
    (tmp_path / "book").mkdir()
    for name in ("_ext", "_static", "node_modules", "package.json"):  # the book's extension
        (tmp_path / "book" / name).symlink_to(ROOT / "book" / name)
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


# --- offline assets, thebe, and how chapters show recordings ---------------------------


def test_config_loads_mathjax_locally_and_not_thebe():
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    sphinx = config["sphinx"]
    extensions = sphinx["config"]["extensions"]
    assert "sphinx_thebe" not in extensions  # it writes `const THEBE_JS_URL` twice per page
    assert "book_assets" in extensions and "book_assets" in sphinx["local_extensions"]
    assert (ROOT / sphinx["local_extensions"]["book_assets"] / "book_assets.py").is_file()
    path = sphinx["config"]["mathjax_path"]
    assert "://" not in path and not path.startswith("/"), "MathJax must come from the book"
    assert path.startswith("vendor/mathjax/")
    assert (Path(path).relative_to("vendor/mathjax").parts[0] in book_assets.MATHJAX_PARTS)


def test_npm_pins_are_exact_and_locked():
    pinned = book_assets.pinned_versions()
    assert set(pinned) == {"mathjax", "@rerun-io/web-viewer"}
    lock = json.loads((ROOT / "book" / "package-lock.json").read_text())["packages"]
    for name, version in pinned.items():
        assert version[0].isdigit(), f"{name} must be pinned to one version, not {version}"
        assert lock[f"node_modules/{name}"]["version"] == version
        assert "resolved" not in lock[f"node_modules/{name}"], "no registry address in git"


def _fake_package(node_modules: Path, name: str, version: str) -> Path:
    folder = node_modules / name
    folder.mkdir(parents=True)
    (folder / "package.json").write_text(json.dumps({"name": name, "version": version}))
    return folder


def test_installed_problem_names_a_missing_or_wrong_package(tmp_path):
    book = tmp_path / "book"
    book.mkdir()
    (book / "package.json").write_text(json.dumps({"dependencies": {"a": "1.0.0",
                                                                    "@s/b": "2.0.0"}}))
    modules = book / "node_modules"
    assert "a is not installed" in book_assets.installed_problem(modules, book)
    _fake_package(modules, "a", "1.0.0")
    _fake_package(modules, "@s/b", "2.1.0")
    assert "@s/b is 2.1.0" in book_assets.installed_problem(modules, book)
    (modules / "@s" / "b" / "package.json").write_text(json.dumps({"version": "2.0.0"}))
    assert book_assets.installed_problem(modules, book) is None


def test_copied_viewer_imports_its_module_by_file_name(tmp_path):
    pkg = _fake_package(tmp_path / "nm", "@rerun-io/web-viewer", "0.0.0")
    (pkg / "index.js").write_text('const m = await import("./re_viewer");\n')
    (pkg / "re_viewer.js").write_text("export default 1;\n")
    (pkg / "re_viewer_bg.wasm").write_bytes(b"\0asm")
    out = book_assets.copy_viewer(tmp_path / "nm", tmp_path / "static")
    assert (out / "index.js").read_text() == 'const m = await import("./re_viewer.js");\n'
    assert (out / "re_viewer_bg.wasm").read_bytes() == b"\0asm"
    (pkg / "index.js").write_text("import { x } from './elsewhere.js';\n")
    with pytest.raises(Exception, match="no longer imports"):
        book_assets.copy_viewer(tmp_path / "nm", tmp_path / "static2")


def test_vendored_mathjax_has_its_entry_point_and_fonts(tmp_path):
    if book_assets.installed_problem():
        pytest.skip(f"{book_assets.installed_problem()} (run `make setup`)")
    out = book_assets.copy_mathjax(book_assets.NODE_MODULES, tmp_path)
    assert (out / "tex-chtml.js").stat().st_size > 100_000
    assert list((out / "output" / "chtml" / "fonts").rglob("*.woff"))
    assert not (out / "tex-svg.js").exists(), "only what tex-chtml.js loads is copied"


def _book(tmp_path: Path) -> Path:
    book = tmp_path / "book"
    (book / "notebooks").mkdir(parents=True)
    (book / "_toc.yml").write_text("root: intro\n")
    (book / "_config.yml").write_text("title: t\n")
    return book


def _recording(folder: Path, name: str, payload: bytes) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.rrd").write_bytes(payload)
    (folder / f"{name}.png").write_bytes(b"\x89PNG" + payload)
    return folder / f"{name}.rrd"


def test_show_recording_stages_files_by_content_and_links_them(tmp_path, monkeypatch):
    book = _book(tmp_path)
    monkeypatch.chdir(book / "notebooks")
    rrd = _recording(tmp_path / "runs", "episode", b"first")
    block = viewer.show_recording(rrd, label="ep <1>")
    (staged,) = block.recordings
    staging = book / viewer.RECORDINGS_STAGING
    assert (staging / staged.rrd).read_bytes() == b"first"
    assert (staging / staged.png).read_bytes() == b"\x89PNGfirst"
    assert staged.rrd.startswith("episode-") and staged.rrd_bytes == 5
    html = block._repr_html_()
    assert html.count('<figure class="icil-recording"') == 1
    assert f'href="../_static/recordings/{staged.rrd}"' in html  # from notebooks/ to the root
    assert 'src="data:image/png;base64,' + base64.b64encode(b"\x89PNGfirst").decode() in html
    items = json.loads(html_lib.unescape(re.search(r'data-recordings="([^"]*)"', html)[1]))
    assert items == [{"label": "ep <1>", "rrd": f"recordings/{staged.rrd}",
                      "png": f"recordings/{staged.png}"}]
    assert "ep &lt;1&gt;" in html and "<1>" not in html
    # a changed recording gets a new name, so a browser never shows a stale copy
    rrd.write_bytes(b"second")
    again = viewer.show_recording(rrd).recordings[0]
    assert again.rrd != staged.rrd and (staging / again.rrd).read_bytes() == b"second"


def test_show_recordings_one_viewer_for_several_and_picture_only(tmp_path, monkeypatch):
    book = _book(tmp_path)
    monkeypatch.chdir(book)
    a = _recording(tmp_path / "runs", "a", b"aa")
    b = _recording(tmp_path / "runs", "b", b"bb")
    block = viewer.show_recordings({"task a": a, "task b": (b, b.with_suffix(".png")),
                                    "task c": (None, a.with_suffix(".png"))})
    html = block._repr_html_()
    items = json.loads(html_lib.unescape(re.search(r'data-recordings="([^"]*)"', html)[1]))
    assert [i["label"] for i in items] == ["task a", "task b"]  # c has no .rrd to view
    assert all(i["rrd"].startswith("recordings/") for i in items)
    assert 'href="_static/recordings/' in html  # a page at the book's root
    assert "Static picture only, no rerun recording was written: task c." in html
    with pytest.raises(FileNotFoundError, match="does not exist"):
        viewer.show_recording(tmp_path / "runs" / "missing.rrd")
    png_only = viewer.show_recording(str(a.with_suffix(".png")))._repr_html_()
    assert 'class="icil-recording-static"' in png_only and "data-recordings" not in png_only


def test_book_root_is_found_from_a_chapter_folder(tmp_path):
    book = _book(tmp_path)
    assert viewer.book_root(book / "notebooks") == book.resolve()
    with pytest.raises(FileNotFoundError):
        viewer.book_root(tmp_path)


def test_plumbing_cells_hide_their_input():
    """A code cell that only imports (and sets up the preset or loads tables) is plumbing:
    it carries `hide-input` (or `remove-input`), so a chapter shows what teaches."""
    import jupytext

    untagged = []
    for path in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py")):
        for cell in jupytext.read(path).cells:
            if cell.cell_type != "code":
                continue
            code = [line for line in cell.source.splitlines()
                    if line.strip() and not line.lstrip().startswith("#")]
            imports_only = code and all(
                line.startswith(("from ", "import ", "    ", ")")) or
                re.match(r"^(preset|store|results)\s*=\s*(get_preset|ResultsStore|load_table)",
                         line) for line in code)
            tags = set(cell.metadata.get("tags", ()))
            if imports_only and not tags & {"hide-input", "remove-input", "remove-cell"}:
                untagged.append(f"{path.name}: {code[0]}")
    assert not untagged, f"import-only cells without hide-input: {untagged}"


BUILT = ROOT / "book" / "_build" / "html" / "notebooks"


@pytest.mark.skipif(not BUILT.is_dir(), reason="the book is not built here (make book)")
def test_the_built_method_chapters_show_the_library_source_of_their_step():
    """In the built book, chapters 02, 03, 05 and 06 hold the source of each object they
    include (`test_chapters.SOURCE_SHOWN`), as highlighted code: the library's own text."""
    from test_chapters import SOURCE_SHOWN

    for chapter, files in SOURCE_SHOWN.items():
        page = BUILT / chapter.replace(".py", ".html")
        text = html_lib.unescape(re.sub(r"<[^>]+>", "", page.read_text()))
        for file, objects in files.items():
            source = (ROOT / file).read_text()
            for name in objects:
                last = name.split(".")[-1]
                assert f"def {last}(" in text, (chapter, name)
                # the first line of its body as the module has it, not a copy that drifted
                body = source.split(f"def {last}(", 1)[1].splitlines()[1].strip()
                assert body in text, (chapter, name, body)


def test_a_block_of_many_recordings_folds_its_download_links(tmp_path, monkeypatch):
    """Up to DOWNLOADS_OPEN links stay in the caption; more go into a closed dropdown that
    still holds every link, so the page stays short and nothing is lost."""
    book = _book(tmp_path)
    monkeypatch.chdir(book)
    files = {f"task {k}": _recording(tmp_path / "runs", f"r{k}", bytes([k + 1]))
             for k in range(viewer.DOWNLOADS_OPEN + 1)}
    few = viewer.show_recordings(dict(list(files.items())[:viewer.DOWNLOADS_OPEN]))._repr_html_()
    assert "<details" not in few and few.count('class="icil-recording-download"') == 3
    many = viewer.show_recordings(files)._repr_html_()
    folded = many.split('<details class="icil-downloads">', 1)[1].split("</details>", 1)[0]
    assert f"Download the {len(files)} recordings</summary>" in folded
    assert folded.count('class="icil-recording-download"') == len(files)
