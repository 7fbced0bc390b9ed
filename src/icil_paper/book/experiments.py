"""The chapters on the experiments (Sec. IV, chapters 06-13): what they show beside the tables.

    show_frame_or(standardized_frame(smooth), NO_SMOOTHNESS)     # chapter 08: Table III
    display(prompt_frame(prompt))                                # chapter 10: the prompts
    comparison_list(findings(result))                            # chapter 11: a Markdown list
    display(Markdown(eq4_differences(results)))                  # chapter 12: Eq. 4 or not
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from icil_paper import stats, verdict_words
from icil_paper.book.report import BUILD, source_label
from icil_paper.tables.assemble import TableResult, format_difference, format_entry
from icil_paper.tables.display import shown_once

Results = Mapping[str, TableResult]
"""{source: TableResult}, as `book.report.load_table` returns them."""


# --------------------------------------------------------------------------- chapter 08
NO_SMOOTHNESS = "*No smoothness records yet.*"
"""What chapter 08 shows where no tokenizer's features were scored yet."""


def _interval(est: Any, digits: int = 3) -> str:
    return f"{est.value:.{digits}f} [{est.low:.{digits}f}, {est.high:.{digits}f}]"


def standardized_frame(smooth: Results) -> pd.DataFrame | None:
    """Table III beside its standardized score by (source, tokenizer); None without records."""
    rows = []
    for source, result in smooth.items():
        for row in result.spec.rows:
            cell = result.entry(row.label, "least_energy")
            if cell is None or cell.estimate is None:
                continue
            metrics = cell.extra["metrics"]
            codes = [m.get("codes_used") for m in metrics]
            rows.append({"source": source_label(source, result.preset), "tokenizer": row.label,
                         "raw": format_entry(cell, 3),
                         "standardized": _interval(cell.extra["standardized_estimate"]),
                         "latent scale σ": round(float(np.mean(cell.extra["latent_scale"])), 4),
                         "codes used": (None if codes[0] is None
                                        else round(float(np.mean(codes)), 1)),
                         "features": metrics[0]["n_features"]})
    return pd.DataFrame(rows).set_index(["source", "tokenizer"]) if rows else None


def tsne_figure(paths: Mapping[str, np.ndarray]):
    """Fig. 4: each tokenizer's t-SNE path ({row: (steps, 2)}), points coloured by time."""
    fig, axes = plt.subplots(1, len(paths), figsize=(2.6 * len(paths), 2.8))
    for ax, (label, xy) in zip(np.atleast_1d(axes), paths.items(), strict=False):
        ax.plot(xy[:, 0], xy[:, 1], color="0.7", zorder=1)
        ax.scatter(xy[:, 0], xy[:, 1], c=np.arange(len(xy)), cmap="viridis", zorder=2)
        ax.set_title(label.split("+")[1])
        ax.set_xticks([]), ax.set_yticks([])
    return shown_once(fig)


FIG4_TITLE = ("Fig. 4: the first steps of one held-out trajectory in each tokenizer's latent "
              "space (t-SNE, colour = time)")
"""The title of Fig. 4's recording."""


def tsne_actions(smooth: TableResult) -> np.ndarray:
    """(steps, A) the actions of the held-out trajectory Fig. 4 follows."""
    first = smooth.entry(smooth.spec.rows[0].label, "least_energy").extra["metrics"][0]
    return np.asarray(first["view_actions"])


# --------------------------------------------------------------------------- chapter 10
def prompt_frame(prompt: Results) -> pd.DataFrame:
    """The prompt ablation's first row against its second and third, paired over the same
    episodes: one row per (source, other prompt), the difference and its verdict."""
    labels = [r.label for r in prompt[BUILD].spec.rows]
    rows = {}
    for source, result in prompt.items():
        for other in labels[1:3]:
            xa, xb = result.outcomes(labels[0]), result.outcomes(other)
            est = None if xa is None or xb is None else stats.paired_difference(xa, xb)
            rows[source_label(source, result.preset), other] = {
                f"'{labels[0]}' minus it": verdict_words.MISSING if est is None
                else format_difference(est),
                "the right prompt is higher": verdict_words.MISSING if est is None
                else stats.verdict(est, +1).value}
    return pd.DataFrame(rows).T


# --------------------------------------------------------------------------- chapter 11
EXPECTED = {-1: "below 0", +1: "above 0"}
"""Where the analysis table's comparisons are expected, by their claimed direction."""


def comparison_list(found: Sequence[Mapping[str, Any]]) -> str:
    """The analysis table's comparisons (`tables.analysis.findings`) as a Markdown list."""
    lines = []
    for f in found:
        value = verdict_words.MISSING if f["estimate"] is None else format_difference(f["estimate"])
        lines.append(f"- {f['quantity']}: {value} (expected {EXPECTED[f['direction']]}): "
                     f"{f['verdict']}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- chapter 12
EQ4_PAIRS = (("icrt+lipvq", "icrt+vq"), ("icrt+lipfsq", "icrt+fsq"),
             ("icrt+liprvq", "icrt+rvq"))
"""Each quantizer with Eq. 4 against itself without (chapter 12)."""


def eq4_differences(results: Results, pairs: Sequence[tuple[str, str]] = EQ4_PAIRS) -> str:
    """Each Eq. 4 variant minus its quantizer, paired, with its interval and verdict, for every
    source, in Markdown."""
    lines = []
    for a, b in pairs:
        lines.append(f"**{a} against {b}**\n")
        for source, result in results.items():
            xa, xb = result.outcomes(a), result.outcomes(b)
            name = source_label(source, result.preset)
            if xa is None or xb is None:
                lines.append(f"- {name}: not run yet.")
                continue
            est = stats.paired_difference(xa, xb)
            lines.append(f"- {name}: '{a}' minus '{b}' = {format_difference(est)}; '{a}' is "
                         f"higher: {stats.verdict(est, +1)}.")
        lines.append("")
    return "\n".join(lines).rstrip("\n")
