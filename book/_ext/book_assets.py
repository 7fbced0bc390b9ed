"""The built book's browser assets, so that it works offline (a Sphinx extension).

Loaded by `_config.yml` (`sphinx.local_extensions`). At the end of an HTML build it copies
into the book's `_static/`:

    vendor/mathjax/             npm `mathjax` (es5 build: tex-chtml.js and what it loads);
                                `mathjax_path` in _config.yml points here, not at a CDN
    vendor/rerun-web-viewer/    npm `@rerun-io/web-viewer` (index.js, re_viewer.js, .wasm)
    recordings/                 the recordings that executed chapters staged with
                                `icil_paper.viz.viewer.show_recording`

and it adds `book/_static/` (recording-viewer.js, recordings.css, tables.css) to every page. In a
Markdown page, `<!-- computed: preset-table -->` becomes every preset's scale (`_computed`);
numbers of results are pasted from the chapters that compute them (MyST-NB's `glue`).
The npm
packages are pinned in `book/package.json` / `package-lock.json` and installed into
`book/node_modules` by `make setup`; a build without them fails and says so.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from sphinx.application import Sphinx
from sphinx.errors import ExtensionError
from sphinx.util import logging

logger = logging.getLogger(__name__)

BOOK_DIR = Path(__file__).resolve().parents[1]
STATIC_DIR = BOOK_DIR / "_static"
NODE_MODULES = BOOK_DIR / "node_modules"

# MathJax's es5 build, less the other combined bundles (tex-svg.js, mml-chtml.js, ...):
# tex-chtml.js loads its fonts, extensions and menu components from these folders.
MATHJAX_PARTS = ("tex-chtml.js", "input", "output", "a11y", "ui", "sre", "adaptors")
VIEWER_FILES = ("index.js", "re_viewer.js", "re_viewer_bg.wasm")
# The package's index.js imports "./re_viewer" without an extension (a bundler resolves it);
# a browser loading the files as they are needs the file's real name.
VIEWER_IMPORT = ('import("./re_viewer")', 'import("./re_viewer.js")')


def pinned_versions(book_dir: Path = BOOK_DIR) -> dict[str, str]:
    """The npm packages and versions that book/package.json pins."""
    return json.loads((book_dir / "package.json").read_text())["dependencies"]


def installed_problem(node_modules: Path = NODE_MODULES, book_dir: Path = BOOK_DIR) -> str | None:
    """None when every pinned npm package is installed at its pinned version, else why not."""
    for name, version in pinned_versions(book_dir).items():
        manifest = node_modules / name / "package.json"
        if not manifest.is_file():
            return f"npm package {name} is not installed in {node_modules}"
        found = json.loads(manifest.read_text())["version"]
        if found != version:
            return f"npm package {name} is {found} in {node_modules}, the book pins {version}"
    return None


def _sync_file(src: Path, dst: Path) -> None:
    """Copy `src` to `dst` unless `dst` already has the same size and is not older."""
    if dst.is_file():
        s, d = src.stat(), dst.stat()
        if s.st_size == d.st_size and d.st_mtime >= s.st_mtime:
            return
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src, dst)


def _sync(src: Path, dst: Path) -> None:
    if src.is_dir():
        for path in src.rglob("*"):
            if path.is_file():
                _sync_file(path, dst / path.relative_to(src))
    else:
        _sync_file(src, dst)


def copy_mathjax(node_modules: Path, static_out: Path) -> Path:
    """MathJax's es5 build into `static_out/vendor/mathjax`; returns that folder."""
    src, dst = node_modules / "mathjax" / "es5", static_out / "vendor" / "mathjax"
    for part in MATHJAX_PARTS:
        _sync(src / part, dst / part)
    return dst


def copy_viewer(node_modules: Path, static_out: Path) -> Path:
    """The rerun web viewer into `static_out/vendor/rerun-web-viewer`; returns that folder."""
    src = node_modules / "@rerun-io" / "web-viewer"
    dst = static_out / "vendor" / "rerun-web-viewer"
    for name in VIEWER_FILES[1:]:
        _sync(src / name, dst / name)
    index = (src / "index.js").read_text()
    old, new = VIEWER_IMPORT
    if index.count(old) != 1 and index.count(new) != 1:
        raise ExtensionError(f"{src / 'index.js'} no longer imports {old} once; check how "
                             "this @rerun-io/web-viewer version loads re_viewer.js")
    dst.mkdir(parents=True, exist_ok=True)
    (dst / "index.js").write_text(index.replace(old, new))
    return dst


def copy_recordings(staging: Path, static_out: Path) -> int:
    """The staged recordings into `static_out/recordings`; returns how many files."""
    from icil_paper.viz.viewer import RECORDINGS_URL_DIR

    if not staging.is_dir():
        return 0
    files = [p for p in staging.iterdir() if p.is_file() and not p.name.startswith(".")]
    for path in files:
        _sync_file(path, static_out / RECORDINGS_URL_DIR / path.name)
    return len(files)


def _check_installed(app: Sphinx) -> None:
    if app.builder.format != "html":
        return
    problem = installed_problem()
    if problem:
        raise ExtensionError(f"{problem}: run `make setup` (or `npm ci --prefix book`)")
    app.config.html_static_path.append(str(STATIC_DIR))


def _copy_assets(app: Sphinx, exception: Exception | None) -> None:
    if exception is not None or app.builder.format != "html":
        return
    from icil_paper.viz.viewer import RECORDINGS_STAGING

    static_out = Path(app.outdir) / "_static"
    copy_mathjax(NODE_MODULES, static_out)
    copy_viewer(NODE_MODULES, static_out)
    n = copy_recordings(Path(app.srcdir) / RECORDINGS_STAGING, static_out)
    logger.info(f"book_assets: MathJax, the rerun web viewer and {n} recording files in "
                f"{static_out}")


def _computed(marker: str) -> str:
    """What a `<!-- computed: NAME -->` marker in a Markdown page stands for (a page is not
    executed, so it cannot compute it itself): `preset-table`, every preset's scale. Numbers
    of results are pasted from the chapters that compute them (MyST-NB's `glue`)."""
    if marker == "preset-table":
        from icil_paper.book.report import preset_table

        return preset_table()
    raise ExtensionError(f"unknown computed marker <!-- computed: {marker} --> (known: "
                         "preset-table)")


def _substitute_computed(app: Sphinx, docname: str, source: list[str]) -> None:
    import re

    source[0] = re.sub(r"<!-- computed: ([a-z-]+) -->", lambda m: _computed(m.group(1)),
                       source[0])


def setup(app: Sphinx) -> dict:
    app.connect("builder-inited", _check_installed)
    app.connect("source-read", _substitute_computed)
    app.connect("build-finished", _copy_assets)
    app.add_js_file("recording-viewer.js", type="module")
    app.add_css_file("recordings.css")
    app.add_css_file("tables.css")
    return {"parallel_read_safe": True, "parallel_write_safe": True}
