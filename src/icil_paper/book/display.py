"""Display helpers the chapters share.

    show_sources(results, comparison_markdown)
    # **reference run.** <its Markdown>
    # **this build (small).** ...
    show_frame_or(frame, "*No smoothness records yet.*")

Each part is a function of one source's TableResult (`book.report.load_table`) that
returns Markdown.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from IPython.display import Markdown, display

from icil_paper.book.report import source_label


def source_paragraph(source: str, result: Any, *parts: Callable[[Any], str],
                     sep: str = " ") -> str:
    """"**<source>.** <part 1> <part 2> ...", joined by `sep` ("\n\n": a list under the name)."""
    return sep.join([f"**{source_label(source, result.preset)}.**",
                     *(part(result) for part in parts)])


def show_sources(results: Mapping[str, Any], *parts: Callable[[Any], str],
                 sep: str = " ") -> None:
    """Display one paragraph per source of a table (`source_paragraph`)."""
    for source, result in results.items():
        display(Markdown(source_paragraph(source, result, *parts, sep=sep)))


def show_frame_or(frame: Any, message: str) -> None:
    """Display `frame`, or `message` (Markdown) where it is None or has no rows."""
    display(Markdown(message) if frame is None or len(frame) == 0 else frame)
