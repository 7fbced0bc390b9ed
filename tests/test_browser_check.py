"""The browser check fails on each kind of problem a built book can have and passes on a
clean one; a recording written by the SDK opens in the embedded viewer."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

from tools import browser_check
from tools.system_deps import find_chromium

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(browser_check.unavailable() is not None,
                                reason=f"browser check cannot run: {browser_check.unavailable()}")

PAGE = ("<!doctype html><html><head><meta charset='utf-8'><title>{title}</title></head>"
        "<body><h1>{title}</h1>{body}</body></html>")

CLEAN = {
    "index.html": '<p>See <a href="sub/other.html#part">the other page</a> and '
                  '<a href="https://example.org/paper">the paper</a> (external links are '
                  'not fetched).</p><img src="img/dot.png" alt="dot">'
                  # TeX inside code is code, not untypeset math
                  r"<pre><code>r'\(x\)' and $$y$$</code></pre>",
    "sub/other.html": '<p id="part">Back <a href="../index.html">home</a>.</p>'
                      '<img src="../img/dot.png" alt="dot">',
}

# Each page has one kind of problem, and the words the check's message must contain.
BROKEN = {
    "js_error.html": ("<script>throw new Error('boom-js')</script>",
                      ["javascript error", "boom-js"]),
    "console_error.html": ("<script>console.error('boom-console')</script>",
                           ["javascript error", "boom-console"]),
    "missing_script.html": ('<script src="nowhere.js"></script>',
                            ["failed request", "nowhere.js", "404"]),
    "cdn_script.html": ('<script src="https://cdn.example.org/lib.js"></script>',
                        ["failed request", "cdn.example.org", "not on the book's server"]),
    "raw_inline_math.html": (r"<p>Energy \(E = mc^2\) in the text.</p>", ["untypeset math"]),
    "raw_display_math.html": (r"<p>$$E = mc^2$$</p>", ["untypeset math", "$$"]),
    "broken_link.html": ('<p><a href="chapters/missing.html">gone</a></p>',
                         ["broken link", "chapters/missing.html"]),
    "broken_image.html": ('<img src="img/missing.png" alt="gone">',
                          ["broken image", "img/missing.png"]),
    "wide_table.html": ('<h2>A wide table</h2><div style="overflow-x: auto; width: 500px">'
                        '<table style="width: 2000px"><tr><td>a</td><td>b</td></tr></table>'
                        '</div>', ["overflow", "A wide table", "px wide"]),
    "table_past_the_column.html": ('<main><article style="width: 600px"><h2>Past the '
                                   'column</h2><table style="width: 1500px"><tr><td>x</td>'
                                   '</tr></table></article></main>',
                                   ["overflow", "Past the column"]),
    "too_tall.html": ('<div style="height: 7000px">a long chapter</div>',
                      ["too tall", "at most 6000"]),
    "dead_viewer.html": ('<figure class="icil-recording" data-recordings=\'[{"label": "x", '
                         '"rrd": "recordings/x.rrd", "png": null}]\'>'
                         '<div class="icil-recording-viewer"></div></figure>',
                         ["recording viewer", "no canvas"]),
}


def _write_site(root: Path, pages: dict[str, str]) -> Path:
    from PIL import Image

    for name, body in pages.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(PAGE.format(title=Path(name).stem, body=body))
    (root / "img").mkdir(exist_ok=True)
    Image.new("RGB", (8, 8), (200, 30, 30)).save(root / "img" / "dot.png")
    return root


def test_clean_site_passes_and_every_page_gets_a_screenshot(tmp_path):
    site = _write_site(tmp_path / "html", CLEAN)
    report = browser_check.run_check(site, tmp_path / "shots", viewer_timeout=10)
    assert report.problems == []
    assert sorted(report.pages) == sorted(CLEAN)
    assert set(report.heights) == set(CLEAN)
    assert all(0 < h <= browser_check.MAX_HEIGHT for h in report.heights.values())
    assert sorted(p.name for p in report.screenshots) == ["index.png", "sub__other.png"]
    for shot in report.screenshots:
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_each_kind_of_problem_fails_its_page(tmp_path):
    pages = {"index.html": CLEAN["index.html"], "sub/other.html": CLEAN["sub/other.html"],
             **{name: body for name, (body, _) in BROKEN.items()}}
    site = _write_site(tmp_path / "html", pages)
    report = browser_check.run_check(site, None, viewer_timeout=2)
    by_page: dict[str, list[str]] = {}
    for problem in report.problems:
        by_page.setdefault(problem.page, []).append(problem.message)
    assert "index.html" not in by_page and "sub/other.html" not in by_page, by_page
    for name, (_, words) in BROKEN.items():
        messages = by_page.get(name, [])
        assert any(all(w in m for w in words) for m in messages), (name, messages)


@pytest.mark.slow
def test_cli_prints_one_line_per_problem_and_exits_nonzero(tmp_path, capsys):
    site = _write_site(tmp_path / "html", {**CLEAN,
                                           "broken_link.html": BROKEN["broken_link.html"][0]})
    assert browser_check.main([str(site), "--screenshots", str(tmp_path / "s")]) == 1
    out = capsys.readouterr().out.splitlines()
    assert [line for line in out if line.startswith("broken_link.html: ")] == [
        "broken_link.html: broken link: chapters/missing.html (no such file)"]
    assert not any(line.startswith("index.html: ") for line in out)
    (site / "broken_link.html").unlink()
    assert browser_check.main([str(site), "--screenshots", str(tmp_path / "s")]) == 0


def test_cli_without_a_built_book_says_so(tmp_path, capsys):
    assert browser_check.main([str(tmp_path / "nothing")]) == 2
    assert "build the book first" in capsys.readouterr().err


def test_redirect_page_is_checked_for_its_target(tmp_path):
    site = _write_site(tmp_path / "html", {"intro.html": "<p>intro</p>"})
    (site / "index.html").write_text('<meta http-equiv="Refresh" content="0; url=intro.html" />')
    (site / "old.html").write_text('<meta http-equiv="Refresh" content="0; url=gone.html" />')
    report = browser_check.run_check(site, None)
    assert [str(p) for p in report.problems] == [
        "old.html: broken link: redirects to gone.html (no such file)"]


def _book_assets():
    spec = importlib.util.spec_from_file_location("book_assets",
                                                  ROOT / "book" / "_ext" / "book_assets.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


CHAPTER = """# %% [markdown]
# # A recorded episode
#
# The energy $E = \\frac{1}{2} m v^2$, and on its own line
#
# $$\\sum_t \\|z_{t+1} - z_t\\|^2$$

# %%
import numpy as np

from icil_paper.viz.recording import record_episode
from icil_paper.viz.viewer import show_recordings

rng = np.random.default_rng(0)
recordings = {}
for name in ("first", "second"):
    obs = {"proprio": np.cumsum(rng.normal(size=(30, 8)) * 0.01, 0),
           "object": np.zeros((30, 10))}
    paths = record_episode(RUN_DIR + f"/{name}.rrd", obs, rng.normal(size=(30, 7)),
                           latents=rng.normal(size=(30, 4)), title=f"the {name} episode",
                           object_position=(0, 3))
    recordings[f"{name} episode"] = paths["rrd"]
show_recordings(recordings)
"""


@pytest.mark.slow
def test_built_book_with_a_recording_passes_offline(tmp_path):
    """A chapter as the book has them, built with the book's own configuration: the SDK
    writes two recordings, `show_recordings` stages them, the book's extension vendors
    MathJax and the npm viewer. In Chromium with no network the math is typeset, the viewer
    starts and reports each recording open (the second through the menu). Opened from
    file://, where the viewer cannot start, the page still shows the static picture and
    links the .rrd file."""
    jupyter_book = Path(sys.executable).with_name("jupyter-book")
    book_assets = _book_assets()
    if not jupyter_book.exists() or book_assets.installed_problem():
        pytest.skip(f"needs jupyter-book and the npm assets ({book_assets.installed_problem()};"
                    " run `make setup`)")
    import rerun

    book = tmp_path / "book"
    (book / "book").mkdir(parents=True)
    shutil.copy(ROOT / "_config.yml", book / "_config.yml")
    for name in ("_ext", "_static", "node_modules", "package.json"):
        (book / "book" / name).symlink_to(ROOT / "book" / name)
    (book / "_toc.yml").write_text(
        "format: jb-book\nroot: intro\nchapters:\n  - file: notebooks/recorded\n")
    (book / "intro.md").write_text("# Intro\n\nInline $a^2 + b^2$ math.\n")
    (book / "notebooks").mkdir()
    (book / "notebooks" / "recorded.py").write_text(
        CHAPTER.replace("RUN_DIR", repr(str(tmp_path / "run"))))
    out = subprocess.run([str(jupyter_book), "build", ".", "--path-output", "book"],
                         cwd=book, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    html = book / "book" / "_build" / "html"
    page = (html / "notebooks" / "recorded.html").read_text()
    assert "THEBE_JS_URL" not in page and "cdn." not in page
    assert 'src="../_static/vendor/mathjax/tex-chtml.js' in page

    report = browser_check.run_check(html, tmp_path / "shots", viewer_timeout=120)
    assert [str(p) for p in report.problems] == []
    assert len(report.recordings_open) == 2  # the second one through the block's menu
    assert all(f"written by rerun-sdk {rerun.__version__}" in line
               for line in report.recordings_open)
    assert {"notebooks__recorded.png", "notebooks__recorded__recording1.png"} <= {
        p.name for p in report.screenshots}

    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=find_chromium(),
                                    args=list(browser_check.CHROMIUM_ARGS))
        pg = browser.new_page()
        pg.goto((html / "notebooks" / "recorded.html").as_uri(), wait_until="load")
        pg.wait_for_timeout(1000)
        fallback = pg.evaluate("""() => {
            const img = document.querySelector("img.icil-recording-fallback");
            return {visible: img.checkVisibility(), width: img.naturalWidth,
                    canvas: !!document.querySelector(".icil-recording canvas"),
                    href: document.querySelector("a.icil-recording-download").href};
        }""")
        browser.close()
    assert fallback["visible"] and fallback["width"] > 0 and not fallback["canvas"]
    downloaded = Path(unquote(urlsplit(fallback["href"]).path))
    assert downloaded.read_bytes() == (tmp_path / "run" / "first.rrd").read_bytes()
