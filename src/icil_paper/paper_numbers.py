"""What the paper states that more than one of its results reads, labelled as the paper's.

Transcribed from the paper's LaTeX source (Vuong, Vu, An, Reid, 2025, Sec. IV): its
training iterations and its seven RoboCasa skill families. Each table's own numbers live
beside its runs and claims, in the module of its result (`icil_paper.paper`), numbered as
in that source: `table_i.TABLE_I_ROBOCASA`, `table_ii.TABLE_II_MANISKILL`,
`table_iii.TABLE_III_SMOOTHNESS`, `table_iv.TABLE_IV_LIPSCHITZ` and
`table_iv.FIG5_CODEBOOK_SIZE`, `table_v.TABLE_V_SIM_TO_REAL`,
`table_vi.TABLE_VI_CROSS_DATASET`, `table_vii.TABLE_VII_ZERO_SHOT`
(`icil_paper.paper.PAPER_TABLES` collects them). They are shown beside our measurements
and quoted by the claims ledger; nothing in the library computes a result from them.
Success rates are fractions in [0, 1]; "avg" is the paper's own average column. Row names
are the policy, or `<policy>+<tokenizer>`.
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


def family_rows(table: dict[str, tuple[float, ...]]) -> dict[str, dict[str, float]]:
    """Row -> {column: number} of a family table (I, VI, VII), from its rows as printed: one
    number per family, then the paper's average."""
    return {row: dict(zip(_FAMILY_COLUMNS, values, strict=True)) for row, values in table.items()}
