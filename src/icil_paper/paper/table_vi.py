"""Table VI: cross-dataset (generated -> human-like scenes and prompts), chapter 10, and the
shift of each Table I row to its Table VI self.

    spec(preset)                          # Table I's rows x seven skill families + avg
    claims(preset)                        # VI-mlp-vs-bc, VI-lipvq-best
    shift_frame(table_i, table_vi)        # TableResults -> one line per row: VI - I
    shift_counts(table_i, table_vi)       # the same, counted per verdict
    TABLE_VI_CROSS_DATASET                # the paper's numbers, as printed

Table I's policies on the `human` scene distribution (ICRT with the human-like prompts), on
Table I's episode seeds. Each row's shift is paired by training seed, d_k = (seed k on human
scenes) - (seed k on generated scenes), read as "the shift lowers this row's success".
"""

from __future__ import annotations

from functools import partial
from typing import Any

from icil_paper import stats, verdict_words
from icil_paper.config import Preset
from icil_paper.paper.table_i import TABLE_I_ROBOCASA, TABLE_I_ROWS
from icil_paper.paper_numbers import family_rows
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, format_difference, format_entry
from icil_paper.tables.claims import Claim, versus
from icil_paper.tables.definitions import (
    FAMILY_COLUMNS,
    TOKENIZER_ROWS,
    family_entries,
    label,
    table_i_runs,
)
from icil_paper.tables.display import show_per_source
from icil_paper.tables.spec import Row, TableSpec

# The paper's Table VI: cross-dataset, trained on MimicGen data, prompted / evaluated with
# human data.
TABLE_VI_CROSS_DATASET = family_rows({
    "mcr":            (0.00, 0.24, 0.20, 0.12, 0.00, 0.00, 0.19, 0.096),
    "act":            (0.00, 0.10, 0.15, 0.13, 0.09, 0.08, 0.05, 0.066),
    "bc_transformer": (0.25, 0.41, 0.73, 0.62, 0.28, 0.18, 0.64, 0.408),
    "icrt+mlp":       (0.21, 0.61, 0.87, 0.77, 0.30, 0.36, 0.52, 0.457),
    "icrt+bin":       (0.26, 0.75, 0.79, 0.74, 0.31, 0.29, 0.60, 0.495),
    "icrt+fast":      (0.30, 0.63, 0.77, 0.74, 0.36, 0.39, 0.42, 0.481),
    "icrt+vq":        (0.21, 0.70, 0.83, 0.77, 0.36, 0.31, 0.60, 0.483),
    "icrt+lfq":       (0.29, 0.65, 0.82, 0.79, 0.38, 0.28, 0.62, 0.503),
    "icrt+lipvq":     (0.32, 0.76, 0.83, 0.71, 0.38, 0.42, 0.64, 0.525),
})


def spec(preset: Preset) -> TableSpec:
    """Table VI: Table I's rows on the `human` scenes (and prompts), per family and avg."""
    tasks = preset.data.robocasa_tasks
    rows = tuple(Row(label(p, t), family_entries(preset, table_i_runs(preset, p, t), tasks,
                                               scenes="human", prompt_source="human"),
                     TABLE_VI_CROSS_DATASET[label(p, t)]) for p, t in TABLE_I_ROWS)
    return TableSpec("VI", "Cross-dataset robotic manipulation (generated -> human-like)",
                     (*FAMILY_COLUMNS, "avg"), rows, note=(
                         "Table I's policies evaluated on the human-like scene distribution: "
                         "every row faces the shift; ICRT rows are prompted with the human-like "
                         "source's demonstrations. avg is the mean over tasks."))


def claims(preset: Preset) -> list[Claim]:
    """Table VI's claims, in the order of the paper's Sec. IV."""
    c = partial(versus, "VI", TABLE_VI_CROSS_DATASET)
    others = [r for r in TOKENIZER_ROWS if r != "icrt+lipvq"]
    return [
        c("icrt+mlp", "bc_transformer", "VI-mlp-vs-bc", "Even with the weakest action tokenizer "
          "(MLP), ICRT outperforms BC-Transformer by 4.9% (cross-dataset).",
          "ICRT+MLP minus BC-Transformer (avg)"),
        c("icrt+lipvq", others, "VI-lipvq-best", "LipVQ-VAE improves other action tokenizers by "
          "2.3% (cross-dataset).", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)"),
    ]


CLAIM_LABELS = {
    "VI-mlp-vs-bc": "cross-dataset: ICRT+MLP beats BC-Transformer",
    "VI-lipvq-best": "cross-dataset: LipVQ-VAE best",
}


# --------------------------------------------------------------------------- the shift from Table I
SHIFT_DIRECTION = -1
"""The claim each row's difference is read against: Table VI - Table I below 0."""


def row_shift(before: TableResult, after: TableResult, row: str,
              column: str = "avg") -> stats.Estimate | None:
    """`after` minus `before` for one row, or None while not run; ValueError when the two
    entries' outcomes cannot be paired."""
    xb, xa = before.outcomes(row, column), after.outcomes(row, column)
    if xa is None or xb is None:
        return None
    if xa.shape != xb.shape:
        raise ValueError(f"{row} ({column}): Table {after.spec.id} has outcomes {xa.shape} and "
                         f"Table {before.spec.id} {xb.shape} (seeds, tasks, episodes); the "
                         "shift is measured on the same policies and episodes")
    return stats.paired_difference(xa, xb, scenes="per_seed")


def _paper_change(row: str, column: str) -> float | None:
    a = TABLE_VI_CROSS_DATASET.get(row, {}).get(column)
    b = TABLE_I_ROBOCASA.get(row, {}).get(column)
    return None if a is None or b is None else float(a) - float(b)


def shift_rows(before: TableResult, after: TableResult,
               column: str = "avg") -> list[dict[str, Any]]:
    """Per row of `after`: row, `before`, `after` (entries), `estimate`, `verdict`, `paper`."""
    out = []
    for spec_row in after.spec.rows:
        est = row_shift(before, after, spec_row.label, column)
        out.append({"row": spec_row.label, "before": before.entry(spec_row.label, column),
                    "after": after.entry(spec_row.label, column), "estimate": est,
                    "verdict": (Verdict.NOT_RUN if est is None
                                else stats.verdict(est, direction=SHIFT_DIRECTION)),
                    "paper": _paper_change(spec_row.label, column)})
    return out


def shift_frame(before: TableResult, after: TableResult, column: str = "avg",
                digits: int = 3):
    """Rows x (Table I, Table VI, VI - I [95% interval], verdict, the paper's VI - I)."""
    import pandas as pd

    i, vi = f"Table {before.spec.id}", f"Table {after.spec.id}"
    lines = []
    for r in shift_rows(before, after, column):
        est = r["estimate"]
        lines.append({
            "": r["row"],
            f"{i} (generated scenes)": format_entry(r["before"], digits),
            f"{vi} (human scenes)": format_entry(r["after"], digits),
            f"{vi} - {i}": (verdict_words.MISSING if est is None
                            else format_difference(est, digits)),
            "lower on the human scenes?": r["verdict"],
            f"paper {vi} - {i}": "" if r["paper"] is None else f"{r['paper']:+.{digits}f}",
        })
    return pd.DataFrame(lines).set_index("")


def shift_counts(before: TableResult, after: TableResult, column: str = "avg"
                 ) -> dict[str, Any]:
    """{"rows", "measured", "mean", "paper_mean", and one count per verdict value}."""
    rows = shift_rows(before, after, column)
    measured = [r for r in rows if r["estimate"] is not None]
    paper_changes = [r["paper"] for r in rows if r["paper"] is not None]
    return {"rows": len(rows), "measured": len(measured),
            "mean": (sum(r["estimate"].value for r in measured) / len(measured)
                     if measured else None),
            "paper_mean": sum(paper_changes) / len(paper_changes) if paper_changes else None,
            **{v.value: sum(r["verdict"] == v for r in measured) for v in Verdict}}


def show_shift(before: dict[str, TableResult], after: dict[str, TableResult],
               column: str = "avg") -> None:
    """`shift_frame` per source, for `load_table`'s results of Tables I and VI."""
    by_preset = {r.preset: r for r in before.values()}
    shown = {k: r for k, r in after.items() if r.preset in by_preset}
    show_per_source(shown, lambda r: shift_frame(by_preset[r.preset], r, column))
