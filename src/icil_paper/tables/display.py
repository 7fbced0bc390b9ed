"""What every result's chapter shows the same way: frames and figures per source.

    results = load_table(preset, "I")     # book.report: {"reference run": ..., "this build": ...}
    show_comparison(results, "avg")       # rows x (paper, reference, this build)
    success_figure(results, "avg")        # bars with 95% intervals, the paper's marks
    show_motion(results, "avg")           # success beside LDLJ, SPARC, action jerk
    show_per_source(results, make_frame)  # any frame per source, the reference run's first
    show_sources(results, make_markdown)  # **reference run.** <its Markdown> ...
    show_frame_or(frame, "*No smoothness records yet.*")
    forest_plot(ledger)                   # each claim's interval, the paper's value, the decision

A chapter shows the paper's numbers and the reference run's side by side; this build's
(which test the code, not the paper) go in a collapsed block (`collapsed_frame`). What only
one result shows lives in its module of `icil_paper.paper`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from icil_paper import verdict_words
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, format_entry, unbroken
from icil_paper.tables.claims import LedgerEntry, as_entry
from icil_paper.tables.definitions import CODEBOOK_TOKENIZERS

REFERENCE = "reference"
"""The reference preset, whose committed records every chapter shows beside this build's."""
BUILD = "this build"
"""The source name of this build's results (its preset is the one the book is built with)."""


SOURCE_WORDS = {f"{REFERENCE} run": "our run", BUILD: "the quick run"}
"""What a table's column or a paragraph calls each source."""


def source_label(source: str, preset_name: str) -> str:
    """"the quick run (small)"; "our run" (its preset is in its source's name already)."""
    words = SOURCE_WORDS.get(source, source)
    return words if preset_name in source else f"{words} ({preset_name})"


def shown_once(fig, **layout):
    """`fig` laid out (`tight_layout(**layout)`) and closed, so that it shows once: where
    the caller displays it."""
    import matplotlib.pyplot as plt

    fig.tight_layout(**layout)
    plt.close(fig)
    return fig


def success_figure(results: dict[str, TableResult], column: str = "avg", title: str = "",
                   ylabel: str = "success rate"):
    """Grouped bars per row: each source's estimate with its 95% interval, the paper's number
    as a black mark; this build left out beside a reference run."""
    import matplotlib.pyplot as plt

    if len(results) > 1:
        results = {k: v for k, v in results.items() if k != BUILD}

    spec = next(iter(results.values())).spec
    labels = [r.label for r in spec.rows]
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(labels) + 2), 3.6))
    width = 0.8 / max(1, len(results))
    x = np.arange(len(labels))
    for k, (source, result) in enumerate(results.items()):
        vals, lo, hi = [], [], []
        for label in labels:
            est = result.estimate(label, column)
            vals.append(est.value if est else np.nan)
            lo.append(est.value - est.low if est else 0.0)
            hi.append(est.high - est.value if est else 0.0)
        ax.bar(x + (k - (len(results) - 1) / 2) * width, vals, width, yerr=[lo, hi], capsize=3,
               label=source_label(source, result.preset), alpha=0.85)
    paper = [next(r for r in spec.rows if r.label == label).paper.get(column) for label in labels]
    if any(p is not None for p in paper):
        ax.scatter(x, [np.nan if p is None else p for p in paper], marker="_", s=400,
                   color="black", zorder=5, label="the paper")
    ax.set_xticks(x, labels, rotation=30, ha="right")
    ax.set_ylabel(ylabel)
    ax.set_title(title or f"Table {spec.id}, {column}")
    ax.legend(fontsize=8, loc="best")
    return shown_once(fig)


def show_comparison(results: dict[str, TableResult], column: str = "avg",
                    digits: int = 3) -> None:
    """Rows x (paper, each source) for one column, as `value [low, high]`: the paper and the
    reference run side by side; this build's numbers collapsed below."""
    import pandas as pd
    from IPython.display import display

    lines = []
    for row in next(iter(results.values())).spec.rows:
        value = row.paper.get(column)
        lines.append({"": row.label, "paper": "" if value is None else f"{value:.{digits}f}",
                      **{source_label(source, result.preset):
                         format_entry(result.entry(row.label, column), digits)
                         for source, result in results.items()}})
    frame = pd.DataFrame(lines).set_index("")
    build = results.get(BUILD)
    if build is None or len(results) == 1:
        display(frame)
        return
    build_column = source_label(BUILD, build.preset)
    display(frame.drop(columns=[build_column]))
    display(collapsed_frame(verdict_words.QUICK_RUN_OPEN.format(preset=build.preset),
                            frame[["paper", build_column]]))


def show_per_source(results: dict[str, TableResult], make_frame, describe=None, empty=None,
                    empty_text: str = verdict_words.MISSING,
                    collapsed: str | None = None) -> None:
    """One frame per source (`make_frame(result)`), this build's collapsed beside a
    reference; `describe(result)` adds a sentence after the source's name; where
    `empty(result, frame)`, one line `empty_text` stands for the frame. With `collapsed`
    (a table of seeds, say), every source's frame is collapsed under
    "<source>: <collapsed>", where `{rows}` stands for its number of rows."""
    from IPython.display import Markdown, display

    for source, result in results.items():
        extra = f": {describe(result)}" if describe else ""
        title = f"**{source_label(source, result.preset)}**"
        frame = make_frame(result)
        if empty is not None and empty(result, frame):
            display(Markdown(f"{title}: {empty_text}"))
        elif collapsed is not None:
            summary = collapsed.format(rows=len(frame))
            display(collapsed_frame(f"{source_label(source, result.preset)}{extra}: {summary}",
                                    frame))
        elif source == BUILD and len(results) > 1:
            display(collapsed_frame(
                verdict_words.QUICK_RUN_OPEN.format(preset=result.preset) + extra, frame))
        else:
            display(Markdown(title + extra))
            display(frame)


COLLAPSED_OPEN = "<details class='icil-build'><summary>{summary}</summary>"
"""The opening of a closed block the reader opens (`collapsed_frame`, `collapsed_markdown`)."""


def collapsed_frame(summary: str, frame) -> Any:
    """A frame inside a closed <details> block (the reader opens it)."""
    from IPython.display import HTML

    return HTML(COLLAPSED_OPEN.format(summary=summary)
                + f"{frame.to_html(classes='dataframe')}</details>")


def collapsed_markdown(summary: str, markdown: str) -> str:
    """Markdown inside a closed <details> block: the blank lines around it let MyST parse
    the Markdown inside the HTML."""
    return f"{COLLAPSED_OPEN.format(summary=summary)}\n\n{markdown}\n\n</details>\n"


def source_paragraph(source: str, result: TableResult, *parts: Callable[[TableResult], str],
                     sep: str = " ") -> str:
    """"**<source>.** <part 1> <part 2> ...", joined by `sep` ("\n\n": a list under the name)."""
    return sep.join([f"**{source_label(source, result.preset)}.**",
                     *(part(result) for part in parts)])


def show_sources(results: dict[str, TableResult], *parts: Callable[[TableResult], str],
                 sep: str = " ") -> None:
    """Display one paragraph per source of a table (`source_paragraph`)."""
    from IPython.display import Markdown, display

    for source, result in results.items():
        display(Markdown(source_paragraph(source, result, *parts, sep=sep)))


def show_frame_or(frame: Any, message: str) -> None:
    """Display `frame`, or `message` (Markdown) where it is None or has no rows."""
    from IPython.display import Markdown, display

    display(Markdown(message) if frame is None or len(frame) == 0 else frame)


MOTION_COLUMNS = {"ldlj": "LDLJ (higher: smoother)", "sparc": "SPARC (higher: smoother)",
                  "action_jerk": "action jerk (lower: smoother)"}
"""The motion frame's columns beside success (`icil_paper.metrics`)."""


def _format_estimate(est, digits: int = 3) -> str:
    """`-12.3 [-13.1, -11.6]` (`digits` significant digits) or `not run`."""
    if est is None:
        return verdict_words.MISSING

    def sig(x: float) -> str:
        return f"{x:#.{digits}g}".rstrip(".").replace(".e", "e")

    return unbroken(f"{sig(est.value)} [{sig(est.low)}, {sig(est.high)}]")


def motion_frame(result: TableResult, column: str = "avg", digits: int = 3):
    """Rows x (success, LDLJ, SPARC, action jerk) of one column, each `value [95% interval]`
    (`TableResult.motion_estimate`)."""
    import pandas as pd

    out = []
    for row in result.spec.rows:
        entry = result.entry(row.label, column)
        line: dict[str, Any] = {"": row.label, "success": unbroken(format_entry(entry, 2))}
        for measure, name in MOTION_COLUMNS.items():
            line[name] = ("n/a" if entry is None else
                          _format_estimate(result.motion_estimate(row.label, column, measure),
                                           digits))
        out.append(line)
    return pd.DataFrame(out).set_index("")


def motion_coverage(result: TableResult, column: str = "avg") -> dict[str, tuple[int, int]]:
    """{measure: (episodes with it defined, episodes)} for the measures some episode lacks."""
    counts = {}
    for row in result.spec.rows:
        entry = result.entry(row.label, column)
        for measure in MOTION_COLUMNS:
            if entry is not None and measure in entry.motion:
                values = entry.motion[measure]
                done, total = counts.get(measure, (0, 0))
                counts[measure] = (done + int(np.isfinite(values).sum()), total + values.size)
    return {MOTION_COLUMNS[m].split(" (")[0]: (d, t) for m, (d, t) in counts.items() if d < t}


def show_motion(results: dict[str, TableResult], column: str = "avg", digits: int = 3) -> None:
    """`motion_frame` per source, then the measures some episodes lack (`motion_coverage`)."""
    from IPython.display import display

    show_per_source(results, lambda r: motion_frame(r, column, digits))
    gaps = {(source, m): {"defined": d, "episodes": t} for source, r in results.items()
            for m, (d, t) in motion_coverage(r, column).items()}
    if gaps:
        import pandas as pd

        display(pd.DataFrame(gaps).T.rename_axis(["source", "measure"]))


def values_frame(result: TableResult, digits: int = 2, paper: bool = False):
    """Point values only (rows x columns); with `paper`, the paper's numbers."""
    import pandas as pd

    def value(row, column):
        entry = result.entry(row.label, column)
        if paper:
            return "" if row.paper.get(column) is None else round(float(row.paper[column]), digits)
        return ("n/a" if entry is None else verdict_words.MISSING if entry.estimate is None
                else round(float(entry.estimate.value), digits))

    rows = result.spec.rows
    return pd.DataFrame({column: [value(row, column) for row in rows]
                         for column in result.spec.columns},
                        index=pd.Index([row.label for row in rows], name=""))


def show_values(results: dict[str, TableResult], digits: int = 2) -> None:
    """The paper's point values, then each source's (`values_frame`), then the columns where
    every row is at 0 or 1."""
    from IPython.display import Markdown, display

    first = next(iter(results.values()))
    display(Markdown("**The paper**"))
    display(values_frame(first, digits, paper=True))
    show_per_source(results, lambda r: values_frame(r, digits), empty_text="not run yet.",
                    empty=lambda r, _: all(c.estimate is None for c in r.entries.values()))
    flat = uninformative_frame(results)
    if not flat.empty:
        display(Markdown("**Uninformative columns**"))
        display(flat.set_index(["source", "column"]))


def uninformative_frame(results: dict[str, TableResult]):
    """Per source, the columns where every row ("all") or every ICRT row is at 0 or every
    one at 1 (the column cannot separate them; "avg" aside), with the share of the average's
    tasks the column holds."""
    import pandas as pd

    def flat(result: TableResult, prefix: str) -> dict[str, float]:
        rows = [r for r in result.spec.rows if r.label.startswith(prefix)]
        out = {}
        for column in result.spec.columns:
            if column in ("avg", "features", "least_energy"):
                continue
            entries = [c for r in rows if (c := result.entry(r.label, column)) is not None]
            values = [c.estimate.value for c in entries if c.estimate is not None]
            if len(values) >= 2 and len(values) == len(entries) and (
                    all(v == 0.0 for v in values) or all(v == 1.0 for v in values)):
                out[column] = values[0]
        return out

    lines = []
    for source, result in results.items():
        tasks = {c: len({u.eval.task for u in entry.units if u.eval is not None})
                 for c, entry in result.spec.rows[0].entries.items()
                 if c not in ("avg", "features")}
        total = sum(tasks.values())
        every = flat(result, "")
        icrt = {c: v for c, v in flat(result, "icrt+").items() if c not in every}
        for rows, found in (("all", every), ("ICRT", icrt)):
            for c, v in found.items():
                lines.append({"source": source_label(source, result.preset), "column": c,
                              "rows": rows, "every row at": v,
                              "share of the average": round(tasks.get(c, 0) / total, 3)
                              if total else 0.0})
    return pd.DataFrame(lines, columns=["source", "column", "rows", "every row at",
                                        "share of the average"])


def seed_correlations(result: TableResult, column: str = "avg") -> dict[tuple[str, str], float]:
    """{(row a, row b): Pearson r of their per-seed success at the same seed index}, over
    at least 3 shared seeds with neither row constant."""
    import pandas as pd

    per_seed = {}
    for row in result.spec.rows:
        entry = result.entry(row.label, column)
        if entry is not None and entry.data is not None and np.ndim(entry.data) >= 2:
            data = np.asarray(entry.data, dtype=np.float64)
            per_seed[row.label] = pd.Series(data.reshape(len(data), -1).mean(axis=1))
    r = pd.DataFrame(per_seed).corr(min_periods=3)  # NaN where a row is constant
    labels = list(per_seed)
    return {(a, b): float(r.loc[a, b]) for i, a in enumerate(labels) for b in labels[i + 1:]
            if np.isfinite(r.loc[a, b])}


# --------------------------------------------------------------------------- features and codebooks
def codebook_rows(result: TableResult, column: str) -> list[tuple[str, Any]]:
    """(row label, its `column` entry spec) of every row whose tokenizer has a codebook."""
    out = []
    for row in result.spec.rows:
        entry = row.entries.get(column)
        tokenizer = entry.units[0].run.tokenizer if entry is not None and entry.units else None
        if tokenizer is not None and tokenizer.type in CODEBOOK_TOKENIZERS:
            out.append((row.label, entry))
    return out


def per_seed_metrics(result: TableResult, label: str, cell_spec, column: str
                      ) -> list[tuple[int, dict[str, Any] | None]]:
    """(training seed, its features metrics or None) per unit of a features entry."""
    units = sorted(cell_spec.units, key=lambda u: u.seed_index)
    entry = result.entry(label, column)
    metrics = entry.extra.get("metrics") if entry is not None and entry.estimate is not None else None
    return [(u.run.seed, metrics[i] if metrics else None) for i, u in enumerate(units)]


def codebook_frame(result: TableResult, column: str = "features"):
    """Codebook use of every codebook row per training seed on Table III's held-out
    trajectories: codes used of `K`, `usage` and the perplexity (exp of the code entropy)."""
    import pandas as pd

    lines = []
    for label, cell_spec in codebook_rows(result, column):
        for seed, m in per_seed_metrics(result, label, cell_spec, column):
            m = m or {}
            lines.append({"row": label, "seed": seed, "codes used": m.get("codes_used"),
                          "K": m.get("codebook_size"), "usage": m.get("usage"),
                          "perplexity": m.get("perplexity"),
                          "status": "ok" if m else verdict_words.MISSING})
    frame = pd.DataFrame(lines, columns=["row", "seed", "codes used", "K", "usage",
                                         "perplexity", "status"])
    return frame.round({"usage": 3, "perplexity": 2}).set_index(["row", "seed"])


def show_codebook_use(results: dict[str, TableResult], column: str = "features") -> None:
    """Each source's `codebook_frame`, collapsed (a row per training seed), or one line
    where its records are not there yet."""
    show_per_source(results, lambda r: codebook_frame(r, column), empty=lambda _, f: (
        f.empty or (f["status"] == verdict_words.MISSING).all()),
        collapsed=verdict_words.PER_SEED_OPEN)


# --------------------------------------------------------------------------- claims
def forest_plot(ledger: Sequence[LedgerEntry | dict[str, Any]], title: str = "",
                label: Callable[[LedgerEntry], str] = lambda e: e.id):
    """One row per claim (`label(entry)`): our estimate and 95% interval coloured by the
    decision, the paper's value (or the effect a claim of ours is sized against) as a
    diamond; one panel per scale of quantity. Claims with too few seeds are drawn dashed."""
    ledger = [as_entry(e) for e in ledger]
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    def panel_of(e):
        quantity = e.quantity.lower()
        return ("rank correlation" if "correlation" in quantity else
                "least energy" if "least energy" in quantity else
                "LDLJ difference" if "ldlj" in quantity else "success difference")

    panels = {}
    for e in ledger:
        panels.setdefault(panel_of(e), []).append(e)
    order = [p for p in ("success difference", "least energy", "LDLJ difference",
                         "rank correlation") if p in panels]
    heights = [len(panels[p]) for p in order]
    fig, axes = plt.subplots(len(order), 1, figsize=(10.5, 0.32 * sum(heights) + 1.2 * len(order) + 0.6),
                             gridspec_kw={"height_ratios": heights}, squeeze=False)
    for ax, name in zip(axes[:, 0], order, strict=True):
        entries = panels[name]
        y = np.arange(len(entries))[::-1]
        for yi, e in zip(y, entries, strict=True):
            verdict = e.adjusted_verdict or e.verdict
            colour = verdict_words.COLOURS.get(verdict, "black")
            if e.ours is not None:
                style = "--" if verdict == Verdict.TOO_FEW_SEEDS else "-"
                ax.plot(e.ci, [yi, yi], style, color=colour, lw=2.2)
                ax.plot(e.ours, yi, "o", color=colour, ms=5)
            if e.paper is not None:
                ax.plot(e.paper, yi, "D", color="black", ms=4, zorder=5)
            elif e.reference_effect is not None:  # the effect a claim of ours is read against
                ax.plot(e.reference_effect, yi, "D", mfc="white", mec="black", ms=4, zorder=5)
        ax.axvline(0, color="#57606a", lw=0.8)
        ax.set_yticks(y, [label(e) for e in entries], fontsize=8)
        ax.set_ylim(-0.7, len(entries) - 0.3)
        sides = {e.direction for e in entries}
        side = ("" if len(sides) > 1 else
                " (the paper claims above 0)" if sides == {1} else " (the paper claims below 0)")
        ax.set_xlabel(name + side, fontsize=8)
        ax.tick_params(axis="x", labelsize=8)
        ax.grid(axis="x", color="#eaeef2", lw=0.6)
    handles = [Line2D([], [], color=c, lw=2.2, ls="--" if v == Verdict.TOO_FEW_SEEDS else "-",
                      label=str(v)) for v, c in verdict_words.COLOURS.items() if v != Verdict.NOT_RUN]
    handles.append(Line2D([], [], color="black", marker="D", ls="", ms=4, label="the paper"))
    if any(e.paper is None and e.reference_effect is not None for e in ledger):
        handles.append(Line2D([], [], mfc="white", mec="black", marker="D", ls="", ms=4,
                              label="reference size (our claims)"))
    fig.legend(handles=handles, fontsize=7, loc="lower center", ncol=len(handles),
               frameon=False)
    axes[0, 0].set_title(title or "Claims: our 95% intervals and the paper's values", fontsize=10)
    return shown_once(fig, rect=(0, 0.04, 1, 1))
