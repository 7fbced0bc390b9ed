"""The paper's own numbers, in one place, labelled as the paper's.

Transcribed from the paper's LaTeX source (Vuong, Vu, An, Reid, 2025, Sec. IV), numbered as
in that source: Table I RoboCasa, II ManiSkill, III smoothness, IV Lipschitz ablation,
V sim-to-real, VI cross-dataset, VII zero-shot; Fig. 5 codebook size. They are shown beside
our measurements and quoted by the claims ledger (`icil_paper.tables.claims`); nothing in
the library computes a result from them. Success rates are fractions in [0, 1]; "avg" is
the paper's own average column. Row names are the policy, or `<policy>+<tokenizer>`.
"""

from __future__ import annotations

SOURCE = ("Vuong, Vu, An, Reid. Action Tokenizer Matters in In-Context Imitation Learning. "
          "2025. Numbers as printed in the paper.")

# Training iterations (Sec. IV-A): RoboCasa 500K, following RoboCasa's standard setting;
# ManiSkill 30K, following ManiSkill's baselines.
ITERATIONS = {"kitchen": 500_000, "maniskill": 30_000}

# The paper's seven RoboCasa skill families (columns of Tables I, VI and VII).
FAMILIES = ("pick_place", "doors", "drawers", "levers", "knobs", "insertion", "buttons")

# Row names: policy or "icrt+<tokenizer>" / "act+<tokenizer>".
_FAMILY_COLUMNS = (*FAMILIES, "avg")


def _rows(table: dict[str, tuple[float, ...]]) -> dict[str, dict[str, float]]:
    return {row: dict(zip(_FAMILY_COLUMNS, values, strict=True)) for row, values in table.items()}


# Table I: success rates on RoboCasa (MimicGen data).
TABLE_I_ROBOCASA = _rows({
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

# Table II: success rates on ManiSkill (ACT with its CVAE action encoder replaced).
TABLE_II_MANISKILL = {
    row: dict(zip(("pick_cube", "push_cube", "stack_cube", "avg"), values, strict=True))
    for row, values in {
        "mcr":            (0.56, 0.51, 0.11, 0.393),
        "act":            (0.20, 0.76, 0.30, 0.420),
        "bc_transformer": (0.04, 0.98, 0.14, 0.387),
        "act+bin":        (0.71, 0.52, 0.25, 0.493),
        "act+fast":       (0.70, 0.48, 0.25, 0.477),
        "act+vq":         (0.64, 0.80, 0.21, 0.550),
        "act+lfq":        (0.74, 0.70, 0.23, 0.557),
        "act+lipvq":      (0.78, 0.77, 0.30, 0.617),
    }.items()
}

# Table III: least-energy smoothness of 500 latent features (lower is smoother).
TABLE_III_SMOOTHNESS = {"icrt+mlp": 5.71, "icrt+bin": 12.57, "icrt+fast": 5.67, "icrt+vq": 4.79,
                        "icrt+lfq": 2.34, "icrt+lipvq": 0.63}

# Table IV: impact of Lipschitz regularization (RoboCasa average success).
TABLE_IV_LIPSCHITZ = {
    "icrt+mlp": {"avg": 0.442},
    "icrt+lip-mlp": {"avg": 0.465},
    "icrt+vq": {"avg": 0.475},
    "icrt+lipvq": {"avg": 0.530},
}

# Fig. 5: LipVQ-VAE codebook size vs RoboCasa average success (from the official plotting code).
FIG5_CODEBOOK_SIZE = {256: 0.475, 512: 0.509, 1024: 0.530, 2048: 0.511}

# Table V: sim-to-real success on a real Kinova Gen3 (ours is a simulated stand-in).
TABLE_V_SIM_TO_REAL = {
    "bc_transformer": {"drawers": 0.02, "doors": 0.02},
    "icrt+bin":       {"drawers": 0.04, "doors": 0.02},
    "icrt+lipvq":     {"drawers": 0.12, "doors": 0.14},
}

# Table VI: cross-dataset, trained on MimicGen data, prompted / evaluated with human data.
TABLE_VI_CROSS_DATASET = _rows({
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

# Table VII: zero-shot, trained on some tasks and evaluated on held-out ones.
TABLE_VII_ZERO_SHOT = _rows({
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

PAPER_TABLES = {
    "I": TABLE_I_ROBOCASA, "II": TABLE_II_MANISKILL, "III": TABLE_III_SMOOTHNESS,
    "IV": TABLE_IV_LIPSCHITZ, "V": TABLE_V_SIM_TO_REAL, "VI": TABLE_VI_CROSS_DATASET,
    "VII": TABLE_VII_ZERO_SHOT,
}
"""Every table of the paper by its number in the paper's source (values as printed)."""
