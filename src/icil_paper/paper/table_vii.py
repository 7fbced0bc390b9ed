"""Table VII: zero-shot, trained on Meta-World's ML45 training tasks and evaluated on its five
held-out tasks, chapter 10.

    spec(preset)                 # Table I's rows x the families with a held-out task + avg
    claims(preset)               # VII-lipvq-vs-bc, VII-lipvq-best
    TABLE_VII_ZERO_SHOT          # the paper's numbers, as printed

Table I's rows trained on `data.zero_shot_tasks` and evaluated on `data.zero_shot_held_out`:
ICRT prompted with a demonstration of the unseen task, the baselines with its instruction.
"""

from __future__ import annotations

from functools import partial

from icil_paper.config import Preset
from icil_paper.paper.table_i import TABLE_I_ROWS
from icil_paper.paper_numbers import family_rows
from icil_paper.tables.claims import Claim, versus
from icil_paper.tables.definitions import (
    FAMILY_COLUMNS,
    TOKENIZER_ROWS,
    family_entries,
    label,
    row_seeds,
    seed_runs,
)
from icil_paper.tables.spec import Row, TableSpec

# The paper's Table VII: zero-shot, trained on some tasks and evaluated on held-out ones.
TABLE_VII_ZERO_SHOT = family_rows({
    "mcr":            (0.00, 0.00, 0.00, 0.06, 0.04, 0.01, 0.00, 0.021),
    "act":            (0.00, 0.00, 0.00, 0.05, 0.04, 0.01, 0.00, 0.019),
    "bc_transformer": (0.00, 0.00, 0.00, 0.10, 0.20, 0.00, 0.00, 0.028),
    "icrt+mlp":       (0.00, 0.01, 0.00, 0.19, 0.22, 0.01, 0.02, 0.047),
    "icrt+bin":       (0.01, 0.01, 0.00, 0.16, 0.24, 0.01, 0.02, 0.046),
    "icrt+fast":      (0.00, 0.00, 0.00, 0.20, 0.12, 0.01, 0.00, 0.041),
    "icrt+vq":        (0.00, 0.00, 0.00, 0.16, 0.20, 0.01, 0.02, 0.041),
    "icrt+lfq":       (0.01, 0.01, 0.00, 0.24, 0.14, 0.02, 0.02, 0.049),
    "icrt+lipvq":     (0.01, 0.00, 0.00, 0.25, 0.24, 0.00, 0.02, 0.052),
})


def spec(preset: Preset) -> TableSpec:
    """Table VII: an entry per family with a held-out task, and "avg"."""
    # `DataConfig` refuses a held-out task among the training tasks
    train, held_out = tuple(preset.data.zero_shot_tasks), tuple(preset.data.zero_shot_held_out)
    rows = []
    for policy, tokenizer in TABLE_I_ROWS:
        seeds = row_seeds(preset, "VII", label(policy, tokenizer), 1)
        runs = seed_runs(preset, policy, tokenizer, train, seeds)
        rows.append(Row(label(policy, tokenizer), family_entries(preset, runs, held_out),
                        TABLE_VII_ZERO_SHOT[label(policy, tokenizer)]))
    return TableSpec("VII", "Zero-shot robotic manipulation results", (*FAMILY_COLUMNS, "avg"),
                     tuple(rows), note=(
                         f"Trained on {len(train)} Meta-World tasks (ML45's training split), "
                         f"evaluated on the {len(held_out)} held out; families without a "
                         "held-out task are n/a."))


def claims(preset: Preset) -> list[Claim]:
    """Table VII's claims, in the order of the paper's Sec. IV."""
    c = partial(versus, "VII", TABLE_VII_ZERO_SHOT)
    others = [r for r in TOKENIZER_ROWS if r != "icrt+lipvq"]
    return [
        c("icrt+lipvq", "bc_transformer", "VII-lipvq-vs-bc", "Our approach surpasses "
          "BC-Transformer by 2.4% (zero-shot).",
          "ICRT+LipVQ minus BC-Transformer (avg over held-out tasks)"),
        c("icrt+lipvq", others, "VII-lipvq-best", "LipVQ-VAE outperforms other tokenizers by at "
          "least 0.2% (zero-shot).", "ICRT+LipVQ minus the best other ICRT tokenizer (avg)"),
    ]


CLAIM_LABELS = {
    "VII-lipvq-vs-bc": "zero-shot: beats BC-Transformer",
    "VII-lipvq-best": "zero-shot: LipVQ-VAE best",
}
