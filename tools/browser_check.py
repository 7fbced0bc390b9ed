"""The built book checked in a real browser: every page loads cleanly, offline.

    python -m tools.browser_check [book/_build/html] [--screenshots DIR]   # make browser-check

Serves the built book on loopback and loads every page in headless Chromium (`find_chromium`
of `tools/system_deps.py`, driven by Playwright; no browser is downloaded), with every request
that leaves the loopback server blocked. A page fails on:

    javascript error     an uncaught exception or a console error
    failed request       a request that failed, was blocked (not loopback) or got HTTP >= 400
    untypeset math       `\\(`, `\\[` or `$$` left in the visible text (outside code)
    broken link/image    a local link (or a redirect's target) to a file not in the book, an
                         image that is not there or does not decode
    overflow             a table, cell output or figure wider than the content column or its
                         own box, at the reader's window width (1400 px)
    recording viewer     a recording block (icil_paper.viz.viewer) whose viewer made no canvas,
                         did not report each of its recordings open, or scrolled the page
    too tall             a page taller than MAX_HEIGHT px at 1400 px wide (collapse tables of
                         seeds and power, or split the chapter)

Prints one line per problem, `<page>: <problem>`, then a summary; exits 1 on any problem, 2
when the check cannot run (no Chromium or Playwright, no built book). Screenshots of every
page and recording block go to `--screenshots` (default `book/_build/screenshots/`).
"""

from __future__ import annotations

import argparse
import functools
import http.server
import re
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urldefrag, urlsplit

from tools.system_deps import find_chromium

DEFAULT_HTML = Path("book/_build/html")
# Chromium on a machine with no display and no network: no first-run, sync or component
# update traffic (those requests would be refused, many at a time). WebGL falls back to
# Chromium's software rasteriser, which the rerun viewer runs on.
CHROMIUM_ARGS = ("--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--disable-quic",
                 "--disable-default-apps", "--mute-audio")
SKIP_DIRS = ("_static", "_sources", "_images", "_sphinx_design_static")
MATH_MARKERS = ("\\(", "\\[", "$$")
VIEWER_STATES_DONE = ("open", "failed")
_REDIRECT = re.compile(r"""<meta\s+http-equiv=["']?refresh["']?\s+content=["'][^"']*?url=([^"'>\s]+)""",
                       re.IGNORECASE)

# Text nodes of the page outside code, scripts and typeset math, where untypeset TeX shows.
_VISIBLE_TEXT_JS = """
() => {
  const skip = "pre, code, script, style, textarea, noscript, mjx-container, .MathJax, .highlight";
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const out = [];
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    const el = node.parentElement;
    if (!el || el.closest(skip)) continue;
    if (el.checkVisibility && !el.checkVisibility()) continue;
    out.push(node.textContent);
  }
  return out.join(" ");
}
"""

VIEWPORT = {"width": 1400, "height": 900}
MAX_HEIGHT = 6000
"""The tallest a page may be at VIEWPORT's width, in CSS px (`Report.heights` has each)."""
"""The reader's window: the width at which nothing may be clipped."""

# Tables, cell outputs and figures that stick out of the content column, or whose content
# is wider than their own box (a clipped or sideways-scrolling output). Code input is left
# alone: a long code line scrolls by design.
_OVERFLOW_JS = """
() => {
  const column = document.querySelector("main article, main, article") || document.body;
  const right = column.getBoundingClientRect().right;
  const out = [];
  const seen = new Set();
  for (const el of column.querySelectorAll(
      "table, .cell_output, .output, figure, img, .dataframe, svg")) {
    if (el.closest(".cell_input, .highlight, pre code")) continue;
    if (el.checkVisibility && !el.checkVisibility()) continue;
    const box = el.getBoundingClientRect();
    if (box.width === 0) continue;
    const wide = el.scrollWidth > el.clientWidth + 1 && el.clientWidth > 0;
    const sticks = box.right > right + 1;
    if (!wide && !sticks) continue;
    let heading = null;
    for (let n = el; n && !heading; n = n.previousElementSibling || n.parentElement) {
      if (/^H[1-4]$/.test(n.tagName)) heading = n.textContent.replace("#", "").trim();
      else { const h = n.querySelector && n.querySelector("h1, h2, h3, h4");
             if (h && n !== el && !n.contains(el)) heading = h.textContent.replace("#", "").trim(); }
    }
    const what = el.tagName.toLowerCase() + (el.className && typeof el.className === "string"
                 ? "." + el.className.split(" ")[0] : "");
    const key = what + "|" + heading;
    if (seen.has(key)) continue;
    seen.add(key);
    out.push({what, heading: (heading || "the page top").slice(0, 60),
              content: Math.round(Math.max(el.scrollWidth, box.width)),
              box: Math.round(wide ? el.clientWidth : right - box.left)});
  }
  return out;
}
"""

_LINKS_JS = """
() => ({
  links: [...document.querySelectorAll("a[href]")].map(a => a.href),
  images: [...document.querySelectorAll("img[src]")].map(img => ({
    src: img.currentSrc || img.src, complete: img.complete, width: img.naturalWidth,
    lazy: img.loading === "lazy"})),
})
"""

_RECORDINGS_JS = """
() => [...document.querySelectorAll("figure.icil-recording")].map(f => ({
  state: f.dataset.viewer || "not started", error: f.dataset.viewerError || "",
  canvas: !!f.querySelector(".icil-recording-viewer canvas"),
  sdk: f.dataset.sdkVersion || "",
  recordings: JSON.parse(f.dataset.recordings || "[]").map(r => r.rrd),
}))
"""

_RECORDING_OPENED_JS = """
([i, rrd]) => {
  const f = document.querySelectorAll("figure.icil-recording")[i];
  return f.dataset.viewer === "open" && f.dataset.opened === rrd;
}
"""

_RECORDINGS_DONE_JS = """
(done) => [...document.querySelectorAll("figure.icil-recording")]
  .every(f => done.includes(f.dataset.viewer))
"""


@dataclass
class Problem:
    page: str
    message: str

    def __str__(self) -> str:
        return f"{self.page}: {self.message}"


@dataclass
class Report:
    """What the check saw: the pages, the problems, the recordings that opened."""

    pages: list[str] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)
    recordings_open: list[str] = field(default_factory=list)
    screenshots: list[Path] = field(default_factory=list)
    heights: dict[str, int] = field(default_factory=dict)
    """Each page's height in px at VIEWPORT's width, its dropdowns closed as a reader finds them."""

    @property
    def ok(self) -> bool:
        return not self.problems


def unavailable() -> str | None:
    """None when the check can run here, else why not (for skips and the CLI)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the Python package playwright is not installed (run `make setup`)"
    if find_chromium() is None:
        return "Chromium is not installed (run `make setup`, or install Debian's chromium)"
    return None


def list_pages(root: Path) -> list[str]:
    """Every HTML page of a built book, as paths relative to `root`, sorted."""
    pages = []
    for path in sorted(root.rglob("*.html")):
        rel = path.relative_to(root)
        if rel.parts[0] in SKIP_DIRS:
            continue
        pages.append(rel.as_posix())
    return pages


class _Handler(http.server.SimpleHTTPRequestHandler):
    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map,
                      ".wasm": "application/wasm", ".js": "text/javascript",
                      ".mjs": "text/javascript", ".rrd": "application/octet-stream"}

    def log_message(self, format, *args):  # noqa: A002 - the base class's signature
        pass


@contextmanager
def serve(root: Path) -> Iterator[str]:
    """Serve `root` on 127.0.0.1 (a free port) in a thread; yields the base URL."""
    server = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), functools.partial(_Handler, directory=str(root)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_port}/"
    finally:
        server.shutdown()
        server.server_close()


def _local_file(root: Path, base: str, url: str) -> Path | None:
    """The file a same-server URL points to (None for other URLs)."""
    url, _ = urldefrag(url)
    if not url.startswith(base):
        return None
    path = root / unquote(urlsplit(url).path).lstrip("/")
    return path / "index.html" if path.is_dir() else path


def _screenshot_name(page: str, part: str = "") -> str:
    return page.removesuffix(".html").replace("/", "__") + (f"__{part}" if part else "") + ".png"


def _check_recordings(pg, page: str, problems: list[str], report: Report,
                      viewer_timeout: float) -> None:
    """Every recording block's viewer starts and opens each of its recordings (a block with
    several is switched through its menu)."""
    try:
        pg.wait_for_function(_RECORDINGS_DONE_JS, arg=list(VIEWER_STATES_DONE),
                             timeout=viewer_timeout * 1000, polling=250)
    except Exception:  # noqa: BLE001 - reported below from each block's state
        pass
    for i, block in enumerate(pg.evaluate(_RECORDINGS_JS)):
        what = f"recording viewer {i + 1} ({block['recordings'][0]})"
        if not block["canvas"]:
            error = f", {block['error']}" if block["error"] else ""
            problems.append(f"{what} did not start: no canvas (state {block['state']}{error})")
            continue
        for k, rrd in enumerate(block["recordings"]):
            if k > 0:  # the menu shows the others, one at a time
                pg.locator("figure.icil-recording").nth(i).locator(
                    "select.icil-recording-menu").select_option(str(k))
            try:
                pg.wait_for_function(_RECORDING_OPENED_JS, arg=[i, rrd],
                                     timeout=viewer_timeout * 1000, polling=250)
            except Exception:  # noqa: BLE001 - a recording that never opens is the problem
                state = pg.evaluate(_RECORDINGS_JS)[i]["state"]
                problems.append(f"recording viewer {i + 1} did not report {rrd} open within "
                                f"{viewer_timeout:.0f} s (state {state})")
                continue
            sdk = pg.evaluate(_RECORDINGS_JS)[i]["sdk"] or "?"
            report.recordings_open.append(f"{page}: {rrd} (written by rerun-sdk {sdk})")


def _check_redirect(root: Path, page: str, report: Report) -> bool:
    """A redirect-only page (jupyter-book's index.html): its target must exist. True if it
    is one (the browser then need not load it)."""
    match = _REDIRECT.search((root / page).read_text(errors="replace")[:4000])
    if match is None:
        return False
    target = (root / page).parent / unquote(urldefrag(match.group(1))[0])
    if not target.is_file():
        report.problems.append(Problem(page, f"broken link: redirects to {match.group(1)} "
                                             "(no such file)"))
    return True


def _check_page(browser, root: Path, base: str, page: str, report: Report,
                screenshots: Path | None, viewer_timeout: float) -> None:
    if _check_redirect(root, page, report):
        return
    problems: list[str] = []
    blocked: set[str] = set()
    context = browser.new_context(viewport=VIEWPORT)

    def route(r):
        url = r.request.url
        if url.startswith(base) or url.startswith(("data:", "blob:")):
            r.continue_()
        else:
            blocked.add(url)
            problems.append(f"failed request: {url} is not on the book's server (blocked; "
                            "the book must work offline)")
            r.abort("blockedbyclient")

    context.route("**/*", route)
    pg = context.new_page()
    pg.on("pageerror", lambda exc: problems.append(f"javascript error: {exc}"))
    pg.on("console", lambda msg: problems.append(f"javascript error: {msg.text}")
          if msg.type == "error" and not msg.text.startswith("Failed to load resource") else None)
    pg.on("requestfailed", lambda req: problems.append(
        f"failed request: {req.url} ({req.failure})") if req.url not in blocked else None)
    pg.on("response", lambda resp: problems.append(
        f"failed request: {resp.url} (HTTP {resp.status})") if resp.status >= 400 else None)
    try:
        pg.goto(base + page, wait_until="load", timeout=60_000)
        # MathJax typesets after load; wait for it where the page has it.
        pg.evaluate("async () => { if (window.MathJax && MathJax.startup && "
                    "MathJax.startup.promise) await MathJax.startup.promise; }")
        if pg.evaluate(_RECORDINGS_JS):
            _check_recordings(pg, page, problems, report, viewer_timeout)
            scrolled = pg.evaluate("() => window.scrollY")
            if scrolled > 0:
                problems.append(f"the page scrolled itself to y={scrolled:.0f} while its "
                                "recording viewers started (a viewer took the focus)")
        pg.wait_for_timeout(300)  # let late console errors and image loads arrive
        text = pg.evaluate(_VISIBLE_TEXT_JS)
        for marker in MATH_MARKERS:
            at = text.find(marker)
            if at >= 0:
                snippet = " ".join(text[max(0, at - 30):at + 40].split())
                problems.append(f"untypeset math: {marker} in the text (…{snippet}…)")
        height = int(pg.evaluate("() => document.documentElement.scrollHeight"))
        report.heights[page] = height
        if height > MAX_HEIGHT:
            problems.append(f"too tall: {height} px at {VIEWPORT['width']} px wide (at most "
                            f"{MAX_HEIGHT}; collapse tables of seeds and power into dropdowns)")
        for o in pg.evaluate(_OVERFLOW_JS):
            problems.append(f"overflow: a {o['what']} under '{o['heading']}' is {o['content']} px "
                            f"wide in {o['box']} px (split, shorten or transpose it)")
        refs = pg.evaluate(_LINKS_JS)
        for url in dict.fromkeys(refs["links"]):
            path = _local_file(root, base, url)
            if path is not None and not path.is_file():
                problems.append(f"broken link: {url.removeprefix(base)} (no such file)")
        for img in refs["images"]:
            path = _local_file(root, base, img["src"])
            if path is not None and not path.is_file():
                problems.append(f"broken image: {img['src'].removeprefix(base)} (no such file)")
            elif img["complete"] and img["width"] == 0 and not img["lazy"]:
                problems.append(f"broken image: {img['src'][:120]} (did not decode)")
        if screenshots is not None:
            pg.evaluate("() => { document.activeElement?.blur(); window.scrollTo(0, 0); }")
            shot = screenshots / _screenshot_name(page)
            pg.screenshot(path=str(shot), full_page=True)
            report.screenshots.append(shot)
            for i, figure in enumerate(pg.locator("figure.icil-recording").all()):
                shot = screenshots / _screenshot_name(page, f"recording{i + 1}")
                figure.screenshot(path=str(shot))
                report.screenshots.append(shot)
    except Exception as exc:  # noqa: BLE001 - a page that cannot load is a problem, not a crash
        problems.append(f"could not be checked: {type(exc).__name__}: {str(exc).splitlines()[0]}")
    finally:
        context.close()
    report.problems.extend(Problem(page, p) for p in dict.fromkeys(problems))


def run_check(root: str | Path = DEFAULT_HTML, screenshots: str | Path | None = None,
              pages: list[str] | None = None, viewer_timeout: float = 120.0) -> Report:
    """Check every page of the built book at `root` (see the module doc); returns a Report.

    Args:
        root: the built HTML folder.
        screenshots: where full-page screenshots go (None: none are taken).
        pages: pages to check, relative to `root` (default: every page).
        viewer_timeout: seconds a page's recording viewers get to open their recordings.
    """
    from playwright.sync_api import sync_playwright

    root = Path(root).resolve()
    if not root.is_dir():
        raise FileNotFoundError(f"{root} is not a folder (build the book first: `make book`)")
    chromium = find_chromium()
    if chromium is None:
        raise FileNotFoundError(unavailable())
    if screenshots is not None:
        screenshots = Path(screenshots)
        screenshots.mkdir(parents=True, exist_ok=True)
        for old in screenshots.glob("*.png"):
            old.unlink()
    report = Report(pages=pages if pages is not None else list_pages(root))
    with serve(root) as base, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=list(CHROMIUM_ARGS))
        try:
            for page in report.pages:
                _check_page(browser, root, base, page, report, screenshots, viewer_timeout)
        finally:
            browser.close()
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.browser_check",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("html", nargs="?", type=Path, default=DEFAULT_HTML,
                        help="the built book's HTML folder (default: %(default)s)")
    parser.add_argument("--screenshots", type=Path, default=None,
                        help="folder for the screenshots (default: screenshots/ beside html)")
    parser.add_argument("--viewer-timeout", type=float, default=120.0,
                        help="seconds for a page's recording viewers to open (default: 120)")
    args = parser.parse_args(argv)
    why_not = unavailable()
    if why_not:
        print(f"browser check: cannot run: {why_not}", file=sys.stderr)
        return 2
    if not args.html.is_dir():
        print(f"browser check: {args.html} is not a folder (build the book first: `make book`)",
              file=sys.stderr)
        return 2
    screenshots = args.screenshots or args.html.resolve().parent / "screenshots"
    start = time.time()
    report = run_check(args.html, screenshots, viewer_timeout=args.viewer_timeout)
    for problem in report.problems:
        print(problem)
    for line in report.recordings_open:
        print(f"recording open: {line}")
    for page, height in report.heights.items():
        print(f"height: {page} {height} px")
    print(f"browser check: {len(report.pages)} pages, {len(report.recordings_open)} recordings "
          f"open in the viewer, {len(report.problems)} problems, {time.time() - start:.0f} s; "
          f"screenshots in {screenshots}")
    return 1 if report.problems else 0


if __name__ == "__main__":
    sys.exit(main())
