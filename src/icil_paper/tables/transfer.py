"""What the cross-dataset shift changes: each row of Table I beside its Table VI self.

    from icil_paper.tables.transfer import shift_frame, shift_sentence
    shift_frame(table_i, table_vi)        # TableResults -> one line per row
    shift_sentence(table_i, table_vi)     # the same, counted in one sentence

Table VI evaluates Table I's trained policies (the same runs, the same training seeds) on
the kitchen suite's `human` scene distribution, ICRT rows with the human-like source's
prompts, on episodes with the same seeds as Table I's. So each row's change is paired by
training seed: for seed k, d_k = (seed k's success on the human scenes) - (seed k's success
on the generated scenes), the same policy in both terms, and the interval is the paired t
interval on the d_k (`stats.paired_difference(vi, i, scenes="per_seed")`, df = S - 1, with
the rule's floor where every d_k agrees). The training seed's own luck cancels from d_k;
what is left is how differently the seeds react to the shift, plus episode noise. A row with
one training seed gets the episodes-only interval and "too few seeds", as everywhere in the
book (`icil_paper.stats`).

The verdict reads the claim "the shift lowers this row's success" (direction -1 on
VI - I): "holds" when the whole interval lies below 0. The paper's own change (its Table VI
minus its Table I, `icil_paper.paper_numbers`) is shown beside ours.
"""

from __future__ import annotations

from typing import Any

from icil_paper import paper_numbers as paper
from icil_paper import stats, verdict_words
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, format_cell

SHIFT_DIRECTION = -1
"""The claim each row's difference is read against: Table VI - Table I below 0."""


def row_shift(before: TableResult, after: TableResult, row: str,
              column: str = "avg") -> stats.Estimate | None:
    """`after` minus `before` for one row (see the module docstring), or None while a cell
    of it has no records. ValueError when the two cells are not the same design (other
    seeds, tasks or episodes), since they could not be paired."""
    xb, xa = before.outcomes(row, column), after.outcomes(row, column)
    if xa is None or xb is None:
        return None
    if xa.shape != xb.shape:
        raise ValueError(f"{row} ({column}): Table {after.spec.id} has outcomes {xa.shape} and "
                         f"Table {before.spec.id} {xb.shape} (seeds, tasks, episodes); the "
                         "shift is measured on the same policies and episodes")
    return stats.paired_difference(xa, xb, scenes="per_seed")


def _paper_change(row: str, column: str) -> float | None:
    a = paper.TABLE_VI_CROSS_DATASET.get(row, {}).get(column)
    b = paper.TABLE_I_ROBOCASA.get(row, {}).get(column)
    return None if a is None or b is None else float(a) - float(b)


def shift_rows(before: TableResult, after: TableResult,
               column: str = "avg") -> list[dict[str, Any]]:
    """One dict per row of `after`: row, its cell in each table (`CellResult` or None), the
    difference's `Estimate` (or None), its verdict ("not run" without records) and the
    paper's change."""
    out = []
    for spec_row in after.spec.rows:
        est = row_shift(before, after, spec_row.label, column)
        out.append({"row": spec_row.label, "before": before.cell(spec_row.label, column),
                    "after": after.cell(spec_row.label, column), "estimate": est,
                    "verdict": (Verdict.NOT_RUN if est is None
                                else stats.verdict(est, direction=SHIFT_DIRECTION)),
                    "paper": _paper_change(spec_row.label, column)})
    return out


def shift_frame(before: TableResult, after: TableResult, column: str = "avg",
                digits: int = 3):
    """Rows x (Table I, Table VI, VI - I with its 95% interval, the verdict on "lower on
    the human scenes", the paper's VI - I), for one column."""
    import pandas as pd

    i, vi = f"Table {before.spec.id}", f"Table {after.spec.id}"
    lines = []
    for r in shift_rows(before, after, column):
        est = r["estimate"]
        lines.append({
            "": r["row"],
            f"{i} (generated scenes)": format_cell(r["before"], digits),
            f"{vi} (human scenes)": format_cell(r["after"], digits),
            f"{vi} - {i}": (verdict_words.MISSING if est is None else
                            f"{est.value:+.{digits}f} [{est.low:+.{digits}f}, "
                            f"{est.high:+.{digits}f}]"),
            "lower on the human scenes?": r["verdict"],
            f"paper {vi} - {i}": "" if r["paper"] is None else f"{r['paper']:+.{digits}f}",
        })
    return pd.DataFrame(lines).set_index("")


def shift_sentence(before: TableResult, after: TableResult, column: str = "avg") -> str:
    """How many rows the shift lowers, raises or leaves undecided, and the mean change over
    the rows measured, in one sentence (generated from the records)."""
    rows = shift_rows(before, after, column)
    measured = [r for r in rows if r["estimate"] is not None]
    if not measured:
        return f"No row has both its Table {before.spec.id} and Table {after.spec.id} records yet."
    counts = {v: sum(r["verdict"] == v for r in measured) for v in Verdict}
    mean = sum(r["estimate"].value for r in measured) / len(measured)
    paper_changes = [r["paper"] for r in rows if r["paper"] is not None]
    text = (f"On the human-like scenes, {len(measured)} of {len(rows)} rows measured: mean "
            f"change {mean:+.3f} in {column} success; lower (the interval below 0) for "
            f"{counts[Verdict.HOLDS]}, higher for {counts[Verdict.DOES_NOT_HOLD]}, inconclusive for "
            f"{counts[Verdict.INCONCLUSIVE]}, and {counts[Verdict.TOO_FEW_SEEDS]} with a single "
            "training seed (too few seeds to decide)")
    if paper_changes:
        text += (f"; the paper's rows change by {sum(paper_changes) / len(paper_changes):+.3f} "
                 "on average from its Table I to its Table VI")
    return text + "."


def show_shift(before: dict[str, TableResult], after: dict[str, TableResult],
               column: str = "avg") -> None:
    """`shift_frame` per source (the reference run's, this build's collapsed beside it), for
    `load_table`'s results of Table I and Table VI; each with its `shift_sentence`."""
    from icil_paper.tables.book import show_per_source

    by_preset = {r.preset: r for r in before.values()}
    shown = {k: r for k, r in after.items() if r.preset in by_preset}
    show_per_source(shown, lambda r: shift_frame(by_preset[r.preset], r, column),
                    describe=lambda r: shift_sentence(by_preset[r.preset], r, column))
