"""The tokenizers since the paper (our own `beyond` table), chapter 12.

    spec(preset)                 # ICRT + VQ-VAE, LipVQ-VAE, FSQ, Lip-FSQ, RVQ, Lip-RVQ, B-spline
    claims(preset)               # beyond-eq4-fsq, beyond-eq4-rvq (claims of our own)

ICRT with FSQ, residual VQ (each without and with Eq. 4) and B-spline control points beside
Table I's VQ-VAE and LipVQ-VAE policies, on Table I's protocol, with features. Its claims
are ours, read against the paper's Eq. 4 gain for VQ-VAE (Table IV).
"""

from __future__ import annotations

from icil_paper.config import Preset
from icil_paper.paper.table_i import TABLE_I_ROBOCASA
from icil_paper.paper.table_iv import TABLE_IV_LIPSCHITZ
from icil_paper.tables.claims import Claim, diff, paper_diff
from icil_paper.tables.definitions import (
    FAMILY_COLUMNS,
    ICRT_TOKENIZERS,
    family_entries,
    features_entry,
    label,
    row_seeds,
    seed_runs,
    table_i_seeds,
)
from icil_paper.tables.spec import Row, TableSpec

SINCE_PAPER_TOKENIZERS = ("vq", "lipvq", "fsq", "lipfsq", "rvq", "liprvq", "bspline")
"""ICRT's tokenizers in the `beyond` table."""


def spec(preset: Preset) -> TableSpec:
    """ICRT with each of `SINCE_PAPER_TOKENIZERS`, success per family and avg, features."""
    tasks = preset.data.robocasa_tasks
    rows = []
    default = preset.tables.since_paper_seeds or preset.tables.icrt_seeds
    for tokenizer in SINCE_PAPER_TOKENIZERS:
        seeds = row_seeds(preset, "beyond", label("icrt", tokenizer), default)
        if tokenizer in ICRT_TOKENIZERS:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", tokenizer))
        runs = seed_runs(preset, "icrt", tokenizer, tasks, seeds)
        entries = family_entries(preset, runs, tasks)
        entries["features"] = features_entry(preset, runs)
        name = label("icrt", tokenizer)
        rows.append(Row(name, entries, TABLE_I_ROBOCASA.get(name, {})))
    return TableSpec("beyond", "Tokenizers since the paper (Meta-World, Table I's protocol)",
                     (*FAMILY_COLUMNS, "avg", "features"), tuple(rows), note=(
                         "ICRT with FSQ, residual VQ (each without and with Eq. 4) and "
                         "B-spline control points beside Table I's VQ-VAE and LipVQ-VAE "
                         "policies, as Table I's rows; `features` as in the analysis table."))


def claims(preset: Preset) -> list[Claim]:
    """The claims of our own on the `beyond` table: does Eq. 4 help every quantizer?"""
    T4 = TABLE_IV_LIPSCHITZ
    return [
        Claim("beyond-eq4-fsq", "beyond", "Ours: Eq. 4's Lipschitz normalisation helps FSQ as "
              "it helps VQ-VAE.", "ICRT+Lip-FSQ minus ICRT+FSQ (avg)", +1,
              diff("beyond", "icrt+lipfsq", "icrt+fsq"),
              paper_diff(T4, "icrt+lipvq", "icrt+vq"), own=True,
              reference="the paper's Eq. 4 gain for VQ-VAE (Table IV)"),
        Claim("beyond-eq4-rvq", "beyond", "Ours: Eq. 4's Lipschitz normalisation helps residual "
              "VQ as it helps VQ-VAE.", "ICRT+Lip-RVQ minus ICRT+RVQ (avg)", +1,
              diff("beyond", "icrt+liprvq", "icrt+rvq"),
              paper_diff(T4, "icrt+lipvq", "icrt+vq"), own=True,
              reference="the paper's Eq. 4 gain for VQ-VAE (Table IV)"),
    ]


CLAIM_LABELS = {
    "beyond-eq4-fsq": "ours: Eq. 4 helps FSQ",
    "beyond-eq4-rvq": "ours: Eq. 4 helps residual VQ",
}
