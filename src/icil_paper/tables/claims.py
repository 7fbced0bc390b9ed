"""The claims ledger: every claim of the paper's Sec. IV, checked against our numbers.

    ledger = claims_ledger(preset, store)          # list of dicts, one per claim
    write_ledger(preset, store)                   # results/<preset>/claims.json

Each claim is a quantity with a claimed direction: "LipVQ-VAE beats BC-Transformer by 5.3
points on Table I" is the difference of the two rows' average success, claimed above 0.
Its `paper` value is computed from the paper's own numbers (`icil_paper.paper_numbers`),
`ours` from our records, `ci` is our 95% interval (paired over the same episodes, see
`icil_paper.stats`) and the verdict follows the rule stated there:

- `holds`: the whole interval lies on the claimed side of 0;
- `does not hold`: the whole interval lies on the other side (we measured the opposite);
- `inconclusive`: the interval contains 0;
- `not run`: a record the claim needs is missing (the run is not finished).

The chapters' verdict sentences are generated from these entries (`sentence`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from icil_paper import paper_numbers as paper
from icil_paper import stats
from icil_paper.config import Preset
from icil_paper.fileio import atomic_write_json
from icil_paper.results import ResultsStore
from icil_paper.tables.assemble import TableResult, assemble
from icil_paper.tables.definitions import ICRT_TOKENIZERS, table_spec

TOKENIZER_ROWS = tuple(f"icrt+{t}" for t in ICRT_TOKENIZERS)
ACT_TOKENIZER_ROWS = ("act+bin", "act+fast", "act+vq", "act+lfq", "act+lipvq")


@dataclass(frozen=True)
class Claim:
    """One claim of the paper and how it is checked."""

    id: str
    """Short identifier, e.g. `I-lipvq-vs-bc`."""
    table: str
    """The table it is about (`I` .. `VII`, `fig5`)."""
    claim: str
    """The paper's sentence (or its gist where the sentence spans a paragraph)."""
    quantity: str
    """What is compared, in words."""
    direction: int
    """+1: claimed above 0; -1: claimed below 0."""
    compute: Callable[[dict[str, TableResult]], stats.Estimate | None]
    """Our estimate from the assembled tables (None when a record is missing)."""
    paper_value: Callable[[], float]
    """The same quantity from the paper's numbers."""


# --------------------------------------------------------------------------- helpers
def _rows(t: TableResult, labels: Sequence[str], column: str = "avg") -> list | None:
    data = [t.outcomes(label, column) for label in labels]
    return None if any(d is None for d in data) else data


def diff(table: str, a: str, b: str, column: str = "avg"):
    def compute(tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = _rows(tables[table], [a, b], column)
        return None if data is None else stats.paired_difference(*data)
    return compute


def margin(table: str, a: str, others: Sequence[str], column: str = "avg"):
    def compute(tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = _rows(tables[table], [a, *others], column)
        return None if data is None else stats.paired_margin(data[0], data[1:])
    return compute


def paper_diff(rows: dict, a: str, b: str, column: str = "avg"):
    return lambda: rows[a][column] - rows[b][column]


def paper_margin(rows: dict, a: str, others: Sequence[str], column: str = "avg"):
    return lambda: rows[a][column] - max(rows[o][column] for o in others)


def _smoothest(tables: dict[str, TableResult]) -> stats.Estimate | None:
    t = tables["III"]
    data = [t.outcomes(r, "least_energy") for r in TOKENIZER_ROWS]
    if any(d is None for d in data):
        return None
    lip = TOKENIZER_ROWS.index("icrt+lipvq")
    others = [d for i, d in enumerate(data) if i != lip]
    return stats.paired_score_margin(data[lip], others)


def _smoothness_success_correlation(tables: dict[str, TableResult]) -> stats.Estimate | None:
    smooth = [tables["III"].outcomes(r, "least_energy") for r in TOKENIZER_ROWS]
    success = [tables["I"].outcomes(r, "avg") for r in TOKENIZER_ROWS]
    if any(x is None for x in smooth + success):
        return None
    return stats.score_success_correlation(smooth, success)


def _paper_correlation() -> float:
    from scipy.stats import spearmanr

    energy = [paper.TABLE_III_SMOOTHNESS[r] for r in TOKENIZER_ROWS]
    success = [paper.TABLE_I_ROBOCASA[r]["avg"] for r in TOKENIZER_ROWS]
    return float(spearmanr(energy, success).statistic)


def _fig5_rows(preset: Preset) -> tuple[str, list[str]]:
    """The sweep row at the paper's 2^10 position (the third of four; its label names the
    paper's size where the preset's differs) and the others."""
    labels = [r.label for r in table_spec(preset, "fig5").rows]
    best = labels[min(2, len(labels) - 1)]
    return best, [x for x in labels if x != best]


# --------------------------------------------------------------------------- the ledger
def claims(preset: Preset) -> list[Claim]:
    """Every claim, in the order of the paper's Sec. IV."""
    T1, T2, T6, T7 = (paper.TABLE_I_ROBOCASA, paper.TABLE_II_MANISKILL,
                      paper.TABLE_VI_CROSS_DATASET, paper.TABLE_VII_ZERO_SHOT)
    T4, T5 = paper.TABLE_IV_LIPSCHITZ, paper.TABLE_V_SIM_TO_REAL
    others = [r for r in TOKENIZER_ROWS if r != "icrt+lipvq"]
    act_others = [r for r in ACT_TOKENIZER_ROWS if r != "act+lipvq"]
    f5_best, f5_others = _fig5_rows(preset)
    return [
        Claim("I-lipvq-best", "I", "Among all action tokenizers, LipVQ-VAE achieves the highest "
              "performance.", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)", +1,
              margin("I", "icrt+lipvq", others), paper_margin(T1, "icrt+lipvq", others)),
        Claim("I-lipvq-vs-bc", "I", "Integrating LipVQ-VAE into ICRT achieves a 5.3% improvement "
              "over BC-Transformer.", "ICRT+LipVQ minus BC-Transformer (avg)", +1,
              diff("I", "icrt+lipvq", "bc_transformer"),
              paper_diff(T1, "icrt+lipvq", "bc_transformer")),
        Claim("I-lipvq-vs-lfq", "I", "LipVQ-VAE surpasses the second-best tokenizer, LFQ-VAE, by "
              "4.1%.", "ICRT+LipVQ minus ICRT+LFQ (avg)", +1,
              diff("I", "icrt+lipvq", "icrt+lfq"), paper_diff(T1, "icrt+lipvq", "icrt+lfq")),
        Claim("I-tokenizer-gap", "I", "An 8.8% performance gap between the best (LipVQ-VAE) and "
              "worst (MLP) tokenizers.", "ICRT+LipVQ minus ICRT+MLP (avg)", +1,
              diff("I", "icrt+lipvq", "icrt+mlp"), paper_diff(T1, "icrt+lipvq", "icrt+mlp")),
        Claim("I-mlp-below-bc", "I", "An ineffective tokenizer can degrade performance, with MLP "
              "underperforming BC-Transformer by 3.5%.", "BC-Transformer minus ICRT+MLP (avg)",
              +1, diff("I", "bc_transformer", "icrt+mlp"),
              paper_diff(T1, "bc_transformer", "icrt+mlp")),
        Claim("II-lipvq-best", "II", "LipVQ-VAE still achieves the highest performance among all "
              "action tokenizers.", "ACT+LipVQ minus the best other ACT+tokenizer (avg)", +1,
              margin("II", "act+lipvq", act_others), paper_margin(T2, "act+lipvq", act_others)),
        Claim("II-lipvq-vs-lfq", "II", "LipVQ-VAE exceeds LFQ-VAE by 6%.",
              "ACT+LipVQ minus ACT+LFQ (avg)", +1, diff("II", "act+lipvq", "act+lfq"),
              paper_diff(T2, "act+lipvq", "act+lfq")),
        Claim("II-lipvq-vs-act", "II", "A 19.7% performance gap in favor of our method over the "
              "original ACT.", "ACT+LipVQ minus ACT (avg)", +1, diff("II", "act+lipvq", "act"),
              paper_diff(T2, "act+lipvq", "act")),
        Claim("III-lipvq-smoothest", "III", "Among all tokenizers, LipVQ-VAE achieves the best "
              "smoothness score.", "LipVQ's least energy minus the lowest other tokenizer's",
              -1, _smoothest, lambda: paper.TABLE_III_SMOOTHNESS["icrt+lipvq"]
              - min(paper.TABLE_III_SMOOTHNESS[r] for r in others)),
        Claim("III-smoother-succeeds", "III", "A clear positive correlation: smoother action "
              "tokenization leads to higher manipulation success rates.",
              "Spearman correlation of least energy and Table I success over the six ICRT "
              "tokenizers (negative: smoother goes with more success)", -1,
              _smoothness_success_correlation, _paper_correlation),
        Claim("IV-mlp", "IV", "Incorporating Lipschitz regularization improves performance by "
              "2.3% for the MLP tokenizer.", "ICRT+Lip-MLP minus ICRT+MLP (avg)", +1,
              diff("IV", "icrt+lip-mlp", "icrt+mlp"),
              paper_diff(T4, "icrt+lip-mlp", "icrt+mlp")),
        Claim("IV-vq", "IV", "Incorporating Lipschitz regularization improves performance by "
              "5.5% for VQ-VAE.", "ICRT+LipVQ minus ICRT+VQ (avg)", +1,
              diff("IV", "icrt+lipvq", "icrt+vq"), paper_diff(T4, "icrt+lipvq", "icrt+vq")),
        Claim("IV-vq-over-mlp", "IV", "VQ-VAE outperforms MLP in both regularized and "
              "non-regularized settings.", "ICRT+VQ minus ICRT+MLP (avg; the regularized pair "
              "is in the chapter)", +1, diff("IV", "icrt+vq", "icrt+mlp"),
              paper_diff(T4, "icrt+vq", "icrt+mlp")),
        Claim("fig5-best", "fig5", "The codebook size of 2^10 yields the best performance.",
              f"LipVQ at {f5_best} minus the best other size of the sweep (avg)", +1, margin("fig5", f5_best, f5_others),
              lambda: paper.FIG5_CODEBOOK_SIZE[1024] - max(
                  v for k, v in paper.FIG5_CODEBOOK_SIZE.items() if k != 1024)),
        Claim("V-lipvq-vs-bc", "V", "ICRT+LipVQ-VAE reaches around 12% while the baselines "
              "struggle to exceed 2% (sim-to-real).", "ICRT+LipVQ minus BC-Transformer (avg "
              "of drawers and doors)", +1, diff("V", "icrt+lipvq", "bc_transformer"),
              lambda: np.mean(list(T5["icrt+lipvq"].values()))
              - np.mean(list(T5["bc_transformer"].values()))),
        Claim("V-lipvq-vs-bin", "V", "ICRT+LipVQ-VAE achieves notably higher success than ICRT "
              "with bin discretization (sim-to-real).", "ICRT+LipVQ minus ICRT+Bin (avg)", +1,
              diff("V", "icrt+lipvq", "icrt+bin"),
              lambda: np.mean(list(T5["icrt+lipvq"].values()))
              - np.mean(list(T5["icrt+bin"].values()))),
        Claim("VI-mlp-vs-bc", "VI", "Even with the weakest action tokenizer (MLP), ICRT "
              "outperforms BC-Transformer by 4.9% (cross-dataset).",
              "ICRT+MLP minus BC-Transformer (avg)", +1, diff("VI", "icrt+mlp", "bc_transformer"),
              paper_diff(T6, "icrt+mlp", "bc_transformer")),
        Claim("VI-lipvq-best", "VI", "LipVQ-VAE improves other action tokenizers by 2.3% "
              "(cross-dataset).", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)", +1,
              margin("VI", "icrt+lipvq", others), paper_margin(T6, "icrt+lipvq", others)),
        Claim("VII-lipvq-vs-bc", "VII", "Our approach surpasses BC-Transformer by 2.4% "
              "(zero-shot).", "ICRT+LipVQ minus BC-Transformer (avg over held-out tasks)", +1,
              diff("VII", "icrt+lipvq", "bc_transformer"),
              paper_diff(T7, "icrt+lipvq", "bc_transformer")),
        Claim("VII-lipvq-best", "VII", "LipVQ-VAE outperforms other tokenizers by at least 0.2% "
              "(zero-shot).", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)", +1,
              margin("VII", "icrt+lipvq", others), paper_margin(T7, "icrt+lipvq", others)),
    ]


def evaluate_claim(claim: Claim, tables: dict[str, TableResult]) -> dict[str, Any]:
    """One ledger entry: the claim, the paper's number, ours with its interval, the verdict."""
    estimate = claim.compute(tables)
    entry = {"id": claim.id, "claim": claim.claim, "table": claim.table,
             "quantity": claim.quantity, "direction": claim.direction,
             "paper": round(float(claim.paper_value()), 4)}
    if estimate is None:
        entry.update(ours=None, ci=None, n=None, method=None, verdict="not run")
    else:
        entry.update(ours=estimate.value, ci=[estimate.low, estimate.high], n=estimate.n,
                     method=estimate.method,
                     verdict=stats.verdict(estimate, direction=claim.direction))
    return entry


def claims_ledger(preset: Preset, store: ResultsStore | None = None) -> list[dict[str, Any]]:
    """Every claim evaluated on the records of `store` (default: the preset's)."""
    store = store or ResultsStore(preset.name)
    needed = {c.table for c in claims(preset)} | {"I"}
    tables = {t: assemble(table_spec(preset, t), store) for t in sorted(needed)}
    return [evaluate_claim(c, tables) for c in claims(preset)]


def write_ledger(preset: Preset, store: ResultsStore | None = None) -> str:
    """Write `results/<preset>/claims.json` (atomically) and return its path."""
    store = store or ResultsStore(preset.name)
    path = store.dir / "claims.json"
    atomic_write_json(path, {"preset": preset.name, "claims": claims_ledger(preset, store)})
    return str(path)


def sentence(entry: dict[str, Any]) -> str:
    """The verdict of one ledger entry in words, for the chapters."""
    if entry["verdict"] == "not run":
        return f"{entry['quantity']}: not run yet (the paper: {entry['paper']:+.3f})."
    low, high = entry["ci"]
    side = "above" if entry["direction"] > 0 else "below"
    words = {"holds": f"holds: our interval lies {side} 0",
             "does not hold": "does not hold: our interval lies on the other side of 0",
             "inconclusive": "is inconclusive: our interval contains 0"}[entry["verdict"]]
    return (f"{entry['quantity']}: the paper {entry['paper']:+.3f}, ours {entry['ours']:+.3f} "
            f"[{low:+.3f}, {high:+.3f}]; the claim {words}.")


def load_ledger(path) -> list[dict[str, Any]]:
    with open(path) as f:
        return json.load(f)["claims"]
