"""Table I: every policy on RoboCasa (Meta-World standing in), chapter 06.

    spec(preset)                 # nine rows x seven skill families + avg (+ features beside)
    claims(preset)               # I-lipvq-best, I-lipvq-vs-bc, I-lipvq-vs-lfq, ...
    TABLE_I_ROBOCASA             # the paper's numbers, as printed

`spec`'s note says what a row is; the other tables reuse its policies
(`definitions.table_i_runs`).
"""

from __future__ import annotations

from functools import partial

from icil_paper.config import Preset
from icil_paper.paper_numbers import family_rows
from icil_paper.tables.claims import Claim, versus
from icil_paper.tables.definitions import (
    FAMILY_COLUMNS,
    TOKENIZER_ROWS,
    family_entries,
    policy_tokenizer,
    table_i_runs,
    with_codebook,
)
from icil_paper.tables.spec import Row, TableSpec

# The paper's Table I: success rates on RoboCasa (MimicGen data).
TABLE_I_ROBOCASA = family_rows({
    "mcr":            (0.00, 0.31, 0.18, 0.17, 0.02, 0.01, 0.22, 0.120),
    "act":            (0.01, 0.13, 0.17, 0.15, 0.12, 0.07, 0.06, 0.083),
    "bc_transformer": (0.29, 0.55, 0.78, 0.62, 0.31, 0.24, 0.78, 0.477),
    "icrt+mlp":       (0.20, 0.61, 0.81, 0.70, 0.32, 0.35, 0.64, 0.442),
    "icrt+bin":       (0.25, 0.75, 0.78, 0.81, 0.32, 0.34, 0.59, 0.483),
    "icrt+fast":      (0.30, 0.59, 0.80, 0.57, 0.39, 0.19, 0.63, 0.471),
    "icrt+vq":        (0.20, 0.70, 0.84, 0.77, 0.27, 0.18, 0.70, 0.475),
    "icrt+lfq":       (0.27, 0.69, 0.83, 0.77, 0.40, 0.27, 0.68, 0.489),
    "icrt+lipvq":     (0.32, 0.80, 0.84, 0.68, 0.41, 0.41, 0.59, 0.530),
})

TABLE_I_ROWS = tuple(policy_tokenizer(row) for row in TABLE_I_ROBOCASA)
"""(policy, tokenizer) of Table I's rows, in the paper's order (also Tables VI's and VII's)."""


def spec(preset: Preset) -> TableSpec:
    """Table I: an entry per family and "avg", and the codebook rows' features beside."""
    tasks = preset.data.robocasa_tasks
    rows = []
    for name, paper in TABLE_I_ROBOCASA.items():
        runs = table_i_runs(preset, *policy_tokenizer(name))
        rows.append(Row(name, with_codebook(preset, family_entries(preset, runs, tasks), runs),
                        paper))
    return TableSpec("I", "Robotic manipulation results on RoboCasa (Meta-World standing in)",
                     (*FAMILY_COLUMNS, "avg"), tuple(rows), beside=("features",), note=(
                         "One multi-task policy per row, trained on every Meta-World task and "
                         "evaluated per task; avg is the mean over tasks. Beside the table, the "
                         "codebook rows' `features` give their codebook use per seed."))


def claims(preset: Preset) -> list[Claim]:
    """Table I's claims, in the order of the paper's Sec. IV."""
    c = partial(versus, "I", TABLE_I_ROBOCASA)
    others = [r for r in TOKENIZER_ROWS if r != "icrt+lipvq"]
    return [
        c("icrt+lipvq", others, "I-lipvq-best", "Among all action tokenizers, LipVQ-VAE achieves "
          "the highest performance.", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)"),
        c("icrt+lipvq", "bc_transformer", "I-lipvq-vs-bc", "Integrating LipVQ-VAE into ICRT "
          "achieves a 5.3% improvement over BC-Transformer.",
          "ICRT+LipVQ minus BC-Transformer (avg)"),
        c("icrt+lipvq", "icrt+lfq", "I-lipvq-vs-lfq", "LipVQ-VAE surpasses the second-best "
          "tokenizer, LFQ-VAE, by 4.1%.", "ICRT+LipVQ minus ICRT+LFQ (avg)"),
        c("icrt+lipvq", "icrt+mlp", "I-tokenizer-gap", "An 8.8% performance gap between the best "
          "(LipVQ-VAE) and worst (MLP) tokenizers.", "ICRT+LipVQ minus ICRT+MLP (avg)"),
        c("bc_transformer", "icrt+mlp", "I-mlp-below-bc", "An ineffective tokenizer can degrade "
          "performance, with MLP underperforming BC-Transformer by 3.5%.",
          "BC-Transformer minus ICRT+MLP (avg)"),
    ]


CLAIM_LABELS = {
    "I-lipvq-best": "LipVQ-VAE best tokenizer, Meta-World",
    "I-lipvq-vs-bc": "ICRT+LipVQ-VAE beats BC-Transformer, Meta-World",
    "I-lipvq-vs-lfq": "LipVQ-VAE beats LFQ-VAE, Meta-World",
    "I-tokenizer-gap": "LipVQ-VAE beats MLP tokenizer, Meta-World",
    "I-mlp-below-bc": "MLP tokenizer below BC-Transformer",
}
