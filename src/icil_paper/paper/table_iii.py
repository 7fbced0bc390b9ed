"""Table III with Figs. 1 and 4: the smoothness of the tokenizers' latent features, chapter 08.

    spec(preset)                         # six ICRT tokenizers x least_energy
    claims(preset)                       # III-lipvq-smoothest, III-smoother-succeeds, and ours
    smoothness_success_figure(smooth, success)   # Fig. 1: least energy against Table I success
    tsne_paths(smooth["this build"])     # Fig. 4: one held-out trajectory in each latent space
    TABLE_III_SMOOTHNESS                 # the paper's numbers, as printed

The least energy of the latents that Table I's ICRT policies' tokenizers give held-out
trajectories (`definitions.feature_spec`).
"""

from __future__ import annotations

import numpy as np

from icil_paper.config import Preset
from icil_paper.paper.table_i import TABLE_I_ROBOCASA
from icil_paper.tables.assemble import TableResult
from icil_paper.tables.claims import Claim, Correlation, MotionCorrelation, margin
from icil_paper.tables.definitions import (
    ICRT_TOKENIZERS,
    TOKENIZER_ROWS,
    features_entry,
    table_i_runs,
)
from icil_paper.tables.display import source_label
from icil_paper.tables.spec import Row, TableSpec

# The paper's Table III: least-energy smoothness of 500 latent features (lower is smoother).
TABLE_III_SMOOTHNESS = {"icrt+mlp": 5.71, "icrt+bin": 12.57, "icrt+fast": 5.67, "icrt+vq": 4.79,
                        "icrt+lfq": 2.34, "icrt+lipvq": 0.63}


def spec(preset: Preset) -> TableSpec:
    """Table III: each ICRT tokenizer's Table I runs x least_energy, a unit per seed."""
    rows = tuple(
        Row(name, {"least_energy": features_entry(preset, table_i_runs(preset, "icrt", tok))},
            {"least_energy": TABLE_III_SMOOTHNESS[name]})
        for tok, name in zip(ICRT_TOKENIZERS, TOKENIZER_ROWS, strict=True))
    return TableSpec("III", "Smoothness of the action tokenizers' latent features",
                     ("least_energy",), rows, measure="smoothness", note=(
                         "Least energy of the latent features that Table I's trained ICRT "
                         "policies' own tokenizers give held-out generated trajectories."))


def _paper_correlation() -> float:
    from scipy.stats import spearmanr

    energy = [TABLE_III_SMOOTHNESS[r] for r in TOKENIZER_ROWS]
    success = [TABLE_I_ROBOCASA[r]["avg"] for r in TOKENIZER_ROWS]
    return float(spearmanr(energy, success).statistic)


def claims(preset: Preset) -> list[Claim]:
    """Table III's claims, in the order of the paper's Sec. IV, then ours."""
    others = [r for r in TOKENIZER_ROWS if r != "icrt+lipvq"]
    return [
        Claim("III-lipvq-smoothest", "III", "Among all tokenizers, LipVQ-VAE achieves the best "
              "smoothness score.", "LipVQ's least energy minus the lowest other tokenizer's",
              -1, margin("III", "icrt+lipvq", others, "least_energy"),
              lambda: TABLE_III_SMOOTHNESS["icrt+lipvq"]
              - min(TABLE_III_SMOOTHNESS[r] for r in others)),
        Claim("III-smoother-succeeds", "III", "A clear positive correlation: smoother action "
              "tokenization leads to higher manipulation success rates.",
              "Spearman correlation of least energy and Table I success over the six ICRT "
              "tokenizers (negative: smoother goes with more success)", -1,
              Correlation(TOKENIZER_ROWS), _paper_correlation),
        Claim("III-smoother-latents-smoother-motion", "III", "Ours: a smoother action "
              "representation goes with smoother motion.", "Spearman correlation of "
              "Table III's least energy and Table I's mean LDLJ of the end-effector path over "
              "the six ICRT tokenizers (negative: smoother latents go with smoother motion)",
              -1, MotionCorrelation(TOKENIZER_ROWS, measure="ldlj"), None, own=True,
              reference="none: the paper has no motion measurement"),
    ]


CLAIM_LABELS = {
    "III-lipvq-smoothest": "LipVQ-VAE's latents smoothest",
    "III-smoother-succeeds": "smoother latents, more success",
    "III-smoother-latents-smoother-motion": "ours: smoother latents, smoother motion",
}


# --------------------------------------------------------------------------- Figs. 1 and 4
def smoothness_success_figure(smooth: dict[str, TableResult], success: dict[str, TableResult],
                              standardized: bool = False):
    """Fig. 1: least energy (Table III) against average success (Table I) with 95% intervals,
    per source, and the paper's points on their own axes."""
    import matplotlib.pyplot as plt

    rows = [r.label for r in next(iter(smooth.values())).spec.rows]
    n = len(smooth) + 1
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6))
    for ax, (source, result) in zip(axes, smooth.items(), strict=False):
        for name in rows:
            entry = result.entry(name, "least_energy")
            s_est = (entry.extra.get("standardized_estimate") if entry and standardized
                     else entry.estimate if entry else None)
            y_est = success[source].estimate(name, "avg")
            if s_est is None or y_est is None:
                continue
            ax.errorbar(s_est.value, y_est.value,
                        xerr=[[s_est.value - s_est.low], [s_est.high - s_est.value]],
                        yerr=[[y_est.value - y_est.low], [y_est.high - y_est.value]],
                        fmt="o", capsize=3)
            ax.annotate(name.split("+")[1], (s_est.value, y_est.value), fontsize=8,
                        xytext=(4, 4), textcoords="offset points")
        ax.set_xlabel(("standardized " if standardized else "") + "least energy (lower: smoother)")
        ax.set_ylabel("average success")
        ax.set_title(source_label(source, result.preset))
    ax = axes[-1]
    for name in rows:
        x, y = TABLE_III_SMOOTHNESS[name], TABLE_I_ROBOCASA[name]["avg"]
        ax.scatter(x, y, color="black")
        ax.annotate(name.split("+")[1], (x, y), fontsize=8, xytext=(4, 4),
                    textcoords="offset points")
    ax.set_xlabel("least energy (the paper)")
    ax.set_ylabel("average success (the paper)")
    ax.set_title("the paper (Table III vs Table I)")
    fig.tight_layout()
    plt.close(fig)  # shown once, by the caller's display(fig)
    return fig


def tsne_paths(smooth: TableResult, seed: int = 0) -> dict[str, np.ndarray]:
    """Fig. 4: {row label: (steps, 2)}, seed 0's latents of one held-out trajectory by t-SNE."""
    from sklearn.manifold import TSNE

    paths = {}
    for row in smooth.spec.rows:
        entry = smooth.entry(row.label, "least_energy")
        if entry is None or entry.estimate is None:
            continue
        z = np.asarray(entry.extra["view"][0], dtype=np.float64)  # (steps, D)
        z = z + 1e-9 * np.random.default_rng(seed).standard_normal(z.shape)  # ties in codes
        perplexity = max(1.0, min(5.0, (len(z) - 1) / 3))
        paths[row.label] = TSNE(n_components=2, perplexity=perplexity, init="pca",
                                random_state=seed).fit_transform(z)
    return paths


def feature_sampling_frame(results: dict[str, TableResult], column: str = "least_energy"):
    """What Table III's features records scored, per source, row and seed: tasks scored and
    asked for (None in older records), steps a task, trajectories and features."""
    import pandas as pd

    lines = []
    for source, result in results.items():
        for row in result.spec.rows:
            entry = result.entry(row.label, column)
            if entry is None or entry.estimate is None:
                continue
            for seed, m in enumerate(entry.extra["metrics"]):
                steps = list((m.get("steps_per_task") or {}).values())
                lines.append({"source": source_label(source, result.preset), "row": row.label,
                              "seed": seed, "tasks scored": (len(m["tasks_scored"])
                                                             if "tasks_scored" in m else None),
                              "tasks": len(m["tasks"]) if "tasks" in m else None,
                              "steps a task": (
                                  "" if not steps else f"{min(steps)}" if min(steps) == max(steps)
                                  else f"{min(steps)}-{max(steps)}"),
                              "trajectories": m["n_trajectories"], "features": m["n_features"]})
    columns = ["source", "row", "seed", "tasks scored", "tasks", "steps a task",
               "trajectories", "features"]
    return pd.DataFrame(lines, columns=columns).set_index(["source", "row", "seed"])
