"""How a chapter shows a rerun recording: an embedded viewer, a download link, the picture.

    from icil_paper.viz.viewer import show_recording, show_recordings
    show_recording("results/small/chapter01/rollout.rrd")           # a notebook cell's last line
    show_recordings({"open_drawer": ("a.rrd", "a.png"), ...})       # one viewer, a menu

The cell stages the `.rrd` file and its picture in `RECORDINGS_STAGING` (named by content
hash) and outputs an HTML block that the built page shows as:

    +--------------------------------------------------+
    | rerun web viewer (canvas), started by            |
    | book/_static/recording-viewer.js                 |
    +--------------------------------------------------+
    | static picture: until the viewer starts, and     |
    | where it cannot (no JavaScript, file://, WebGL)  |
    +--------------------------------------------------+
    | download link to the .rrd, `rerun <file>` hint   |
    +--------------------------------------------------+

The book's extension (`book/_ext/book_assets.py`) copies the staged files into
`_static/recordings/`, so the book is self-contained.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

RECORDINGS_STAGING = Path("book") / "_build" / "recordings"
"""Where executed chapters stage recordings, relative to the book's root."""

RECORDINGS_URL_DIR = "recordings"
"""The recordings' folder inside the built book's `_static/`."""

DEFAULT_HEIGHT = "520px"

DOWNLOADS_OPEN = 3
"""A block of more recordings than this lists their download links in a closed dropdown."""


def book_root(start: str | Path | None = None) -> Path:
    """The nearest folder at or above `start` (default: cwd) with `_toc.yml` and `_config.yml`."""
    here = Path(start or Path.cwd()).resolve()
    for folder in (here, *here.parents):
        if (folder / "_toc.yml").is_file() and (folder / "_config.yml").is_file():
            return folder
    raise FileNotFoundError(f"no book root (a folder with _toc.yml and _config.yml) at or "
                            f"above {here}; pass book_root=")


@dataclass(frozen=True)
class StagedRecording:
    """One recording as the built book serves it."""

    label: str
    """What the reader sees it called."""
    rrd: str | None
    """File name of the staged `.rrd` under `_static/recordings/`, or None (picture only)."""
    png: str | None
    """File name of the staged picture, or None."""
    rrd_bytes: int = 0
    """Size of the `.rrd` file, for the download link."""


def _stage(label: str, rrd: str | Path | None, png: str | Path | None,
           staging: Path) -> StagedRecording:
    """Copy one recording (and its picture) into `staging` under content-hashed names."""
    rrd = Path(rrd) if rrd is not None else None
    if rrd is not None and rrd.suffix.lower() == ".png":  # a picture-only recording
        rrd, png = None, png or rrd
    if png is None and rrd is not None and rrd.with_suffix(".png").is_file():
        png = rrd.with_suffix(".png")
    png = Path(png) if png is not None else None
    for path in (rrd, png):
        if path is not None and not path.is_file():
            raise FileNotFoundError(f"recording {label!r}: {path} does not exist")
    if rrd is None and png is None:
        raise ValueError(f"recording {label!r}: neither an .rrd file nor a picture given")
    stem = (rrd or png).stem
    content = b"".join(path.read_bytes() for path in (rrd, png) if path is not None)
    digest = hashlib.sha256(content).hexdigest()[:12]
    staging.mkdir(parents=True, exist_ok=True)
    names: dict[str, str | None] = {"rrd": None, "png": None}
    for key, path in (("rrd", rrd), ("png", png)):
        if path is not None:
            names[key] = f"{stem}-{digest}{path.suffix.lower()}"
            target, tmp = staging / names[key], staging / f".{names[key]}.tmp"
            if not target.exists():  # content-addressed: an existing file is the same bytes
                shutil.copyfile(path, tmp)
                os.replace(tmp, target)
    return StagedRecording(label, names["rrd"], names["png"],
                           rrd.stat().st_size if rrd is not None else 0)


def _sdk_hint() -> str:
    """Which rerun to open the files with: the SDK version that wrote them."""
    try:
        return f" (<code>pip install rerun-sdk=={version('rerun-sdk')}</code>)"
    except PackageNotFoundError:
        return ""


@dataclass
class RecordingBlock:
    """A notebook output: the HTML block for one or more recordings (see the module doc)."""

    recordings: list[StagedRecording]
    staging: Path  # where the staged files are
    page_prefix: str  # from the page to the book's root, e.g. "../"
    height: str

    def _repr_html_(self) -> str:
        items = [{"label": r.label, "rrd": f"{RECORDINGS_URL_DIR}/{r.rrd}",
                  "png": f"{RECORDINGS_URL_DIR}/{r.png}" if r.png else None}
                 for r in self.recordings if r.rrd is not None]
        viewable = [r for r in self.recordings if r.rrd is not None]
        first = (viewable or self.recordings)[0]  # the one the viewer (or picture) shows
        parts = []
        if items:
            parts.append(f'<figure class="icil-recording" '
                         f'data-recordings="{html.escape(json.dumps(items))}" '
                         f'data-height="{html.escape(self.height)}">')
            parts.append('<div class="icil-recording-viewer"></div>')
        else:
            parts.append('<figure class="icil-recording-static">')
        if first.png:
            # Inlined, so that the picture shows wherever the output is opened (the built
            # book, a page opened from disk, Jupyter); the menu loads the others by address.
            data = base64.b64encode((self.staging / first.png).read_bytes()).decode()
            parts.append(f'<img class="icil-recording-fallback" src="data:image/png;base64,{data}" '
                         f'alt="static picture of the recording: {html.escape(first.label)}">')
        caption = []
        if viewable:
            links = [f'<a class="icil-recording-download" download '
                     f'data-rrd="{RECORDINGS_URL_DIR}/{r.rrd}" '
                     f'href="{self.page_prefix}_static/{RECORDINGS_URL_DIR}/{r.rrd}">'
                     f"{html.escape(r.label)}</a> ({r.rrd_bytes / 1024:,.0f} kB)"
                     for r in viewable]
            text = (f"{'; '.join(links)}. Open a downloaded file with "
                    f"<code>rerun &lt;file&gt;.rrd</code>{_sdk_hint()}.")
            if len(links) > DOWNLOADS_OPEN:
                caption.append(f'<details class="icil-downloads"><summary>Download the '
                               f"{len(links)} recordings</summary>{text}</details>")
            else:
                caption.append(f"Download the recording{'s' if len(links) > 1 else ''}: {text}")
        pictures_only = [html.escape(r.label) for r in self.recordings if r.rrd is None]
        if pictures_only:
            caption.append("Static picture only, no rerun recording was written: "
                           f"{', '.join(pictures_only)}.")
        parts.append(f"<figcaption>{' '.join(caption)}</figcaption>")
        parts.append("</figure>")
        return "\n".join(parts)

    def __repr__(self) -> str:
        return "\n".join(f"rerun recording {r.label}: {r.rrd or r.png}" for r in self.recordings)


def _page_prefix(root: Path) -> str:
    """The relative path from the executing chapter's page to the book's root ("../")."""
    try:
        rel = Path.cwd().resolve().relative_to(root)
    except ValueError:
        return ""
    return "../" * len(rel.parts)


def show_recordings(recordings: Mapping[str, str | Path | tuple] | Sequence[str | Path],
                    height: str = DEFAULT_HEIGHT, root: str | Path | None = None
                    ) -> RecordingBlock:
    """One embedded viewer for several recordings, with a menu to pick one.

    `recordings`: {label: rrd} or {label: (rrd, png)}, or a list of rrd paths; an rrd that
    is None or a `.png` shows as its picture only, and the picture defaults to the `.png`
    beside the `.rrd`. Returns the block to display; FileNotFoundError for a missing file.
    """
    if not isinstance(recordings, Mapping):
        recordings = {Path(p).stem: p for p in recordings}
    if not recordings:
        raise ValueError("no recordings to show")
    root = Path(root).resolve() if root is not None else book_root()
    staging = root / RECORDINGS_STAGING
    staged = []
    for label, spec in recordings.items():
        rrd, png = spec if isinstance(spec, tuple) else (spec, None)
        staged.append(_stage(str(label), rrd, png, staging))
    return RecordingBlock(staged, staging, _page_prefix(root), height)


def show_recording(rrd: str | Path | None, png: str | Path | None = None,
                   label: str | None = None, height: str = DEFAULT_HEIGHT,
                   root: str | Path | None = None) -> RecordingBlock:
    """One recording in an embedded rerun viewer, with its picture (default: the `.png`
    beside `rrd`) and a download link; `label` defaults to the file's stem."""
    path = rrd if rrd is not None else png
    if path is None:
        raise ValueError("show_recording needs an .rrd file or a picture")
    return show_recordings({label or Path(path).stem: (rrd, png)}, height=height, root=root)
