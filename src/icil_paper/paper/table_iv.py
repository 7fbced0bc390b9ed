"""Table IV with Fig. 5: Eq. 4's Lipschitz regularization and LipVQ-VAE's codebook size,
chapter 09.

    spec(preset)                 # MLP, Lip-MLP, VQ-VAE, LipVQ-VAE x avg (+ features beside)
    fig5_spec(preset)            # LipVQ-VAE at the preset's codebook sizes x avg
    claims(preset)               # IV-mlp, IV-vq, IV-vq-over-mlp, fig5-best
    codes_used_frame(fig5)       # Fig. 5's numbers: codes used of each size's K
    TABLE_IV_LIPSCHITZ, FIG5_CODEBOOK_SIZE   # the paper's numbers, as printed

Table IV's rows and Fig. 5's size at the preset's codebook size are Table I's policies;
Fig. 5's i-th size stands beside the paper's i-th (2^8 .. 2^11).
"""

from __future__ import annotations

import dataclasses
from functools import partial

import numpy as np

from icil_paper.config import Preset
from icil_paper.tables.assemble import TableResult
from icil_paper.tables.claims import Claim, margin, versus
from icil_paper.tables.definitions import (
    policy_tokenizer,
    row_seeds,
    seed_runs,
    table_i_runs,
    table_i_seeds,
    tasks_entry,
    with_codebook,
)
from icil_paper.tables.display import codebook_rows, per_seed_metrics, source_label
from icil_paper.tables.spec import Row, TableSpec

# The paper's Table IV: impact of Lipschitz regularization (RoboCasa average success).
TABLE_IV_LIPSCHITZ = {
    "icrt+mlp": {"avg": 0.442},
    "icrt+lip-mlp": {"avg": 0.465},
    "icrt+vq": {"avg": 0.475},
    "icrt+lipvq": {"avg": 0.530},
}

# The paper's Fig. 5: LipVQ-VAE codebook size vs RoboCasa average success (from the official
# plotting code).
FIG5_CODEBOOK_SIZE = {256: 0.475, 512: 0.509, 1024: 0.530, 2048: 0.511}


def spec(preset: Preset) -> TableSpec:
    """Table IV: ICRT with MLP, Lip-MLP, VQ-VAE and LipVQ-VAE x avg, features beside."""
    tasks = preset.data.robocasa_tasks
    rows = []
    for name, paper in TABLE_IV_LIPSCHITZ.items():
        runs = table_i_runs(preset, *policy_tokenizer(name))
        rows.append(Row(name, with_codebook(preset, {"avg": tasks_entry(preset, runs, tasks)},
                                            runs), paper))
    return TableSpec("IV", "Lipschitz regularization's impact", ("avg",), tuple(rows),
                     beside=("features",),
                     note="Average success over the Meta-World tasks; MLP and VQ-VAE rows are "
                          "Table I's. Beside the table, the codebook rows' `features` give "
                          "their codebook use per seed.")


def fig5_spec(preset: Preset) -> TableSpec:
    """Fig. 5: ICRT + LipVQ-VAE at each of `tables.codebook_sizes` x avg."""
    tasks = preset.data.robocasa_tasks
    base = preset.tokenizers.lipvq
    rows = []
    paper_sizes = sorted(FIG5_CODEBOOK_SIZE)
    for i, size in enumerate(sorted(preset.tables.codebook_sizes)):
        tok = dataclasses.replace(base, codebook_size=size)
        seeds = row_seeds(preset, "fig5", str(size), 1)
        if size == base.codebook_size:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", "lipvq"))
        runs = seed_runs(preset, "icrt", tok, tasks, seeds)
        name = _power_of_two(size)
        paper_size = paper_sizes[i] if i < len(paper_sizes) else None
        if paper_size is not None and paper_size != size:
            name += f" (the paper's {_power_of_two(paper_size)})"
        entries = with_codebook(preset, {"avg": tasks_entry(preset, runs, tasks)}, runs)
        rows.append(Row(name, entries,
                        {"avg": FIG5_CODEBOOK_SIZE[paper_size]} if paper_size else {}))
    return TableSpec("fig5", "Impact of LipVQ-VAE's codebook size (Fig. 5)", ("avg",),
                     tuple(rows), beside=("features",), note=(
                         "ICRT + LipVQ-VAE with codebook sizes "
                         f"{list(preset.tables.codebook_sizes)} (the preset's Table I entry uses "
                         f"{base.codebook_size}). Beside the table, each size's `features` give "
                         "its codebook use."))


def _power_of_two(size: int) -> str:
    """"2^8" for 256; other sizes as they are."""
    exponent = size.bit_length() - 1
    return f"2^{exponent}" if 2**exponent == size else str(size)


def claims(preset: Preset) -> list[Claim]:
    """Table IV's and Fig. 5's claims, in the order of the paper's Sec. IV."""
    c = partial(versus, "IV", TABLE_IV_LIPSCHITZ)
    f5_rows = [r.label for r in fig5_spec(preset).rows]
    f5_best = f5_rows[min(2, len(f5_rows) - 1)]  # at the paper's 2^10 position, the third
    f5_others = [x for x in f5_rows if x != f5_best]
    return [
        c("icrt+lip-mlp", "icrt+mlp", "IV-mlp", "Incorporating Lipschitz regularization "
          "improves performance by 2.3% for the MLP tokenizer.",
          "ICRT+Lip-MLP minus ICRT+MLP (avg)"),
        c("icrt+lipvq", "icrt+vq", "IV-vq", "Incorporating Lipschitz regularization improves "
          "performance by 5.5% for VQ-VAE.", "ICRT+LipVQ minus ICRT+VQ (avg)"),
        c("icrt+vq", "icrt+mlp", "IV-vq-over-mlp", "VQ-VAE outperforms MLP in both regularized "
          "and non-regularized settings.", "ICRT+VQ minus ICRT+MLP (avg; the regularized pair "
          "is in the chapter)"),
        Claim("fig5-best", "fig5", "The codebook size of 2^10 yields the best performance.",
              f"LipVQ at {f5_best} minus the best other size of the sweep (avg)", +1,
              margin("fig5", f5_best, f5_others),
              lambda: FIG5_CODEBOOK_SIZE[1024] - max(
                  v for k, v in FIG5_CODEBOOK_SIZE.items() if k != 1024)),
    ]


CLAIM_LABELS = {
    "IV-mlp": "Eq. 4 helps the MLP tokenizer",
    "IV-vq": "Eq. 4 helps VQ-VAE",
    "IV-vq-over-mlp": "VQ-VAE beats MLP tokenizer",
    "fig5-best": "codebook of 2^10 best",
}


def codes_used_frame(results: dict[str, TableResult], column: str = "features"):
    """Per source and codebook row: codes used of K and perplexity, means over seeds."""
    import pandas as pd

    lines = []
    for source, result in results.items():
        for row, cell_spec in codebook_rows(result, column):
            measured = [m for _, m in per_seed_metrics(result, row, cell_spec, column)
                        if m and m.get("codes_used") is not None]
            used = float(np.mean([m["codes_used"] for m in measured])) if measured else None
            size = measured[0]["codebook_size"] if measured else None
            perplexities = [m["perplexity"] for m in measured if m.get("perplexity") is not None]
            lines.append({"source": source_label(source, result.preset), "row": row,
                          "seeds": len(measured), "codes used": used, "K": size,
                          "share": None if used is None else round(used / size, 3),
                          "perplexity": (round(float(np.mean(perplexities)), 1)
                                         if perplexities else None)})
    columns = ["source", "row", "seeds", "codes used", "K", "share", "perplexity"]
    return pd.DataFrame(lines, columns=columns).set_index(["source", "row"])
