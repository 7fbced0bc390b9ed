"""What the paper states that more than one of its results reads, labelled as the paper's.

Transcribed from the paper's LaTeX source (Vuong, Vu, An, Reid, 2025, Sec. IV). Each table's
own numbers live in the module of its result (`icil_paper.paper.PAPER_TABLES` collects them):
success rates as fractions in [0, 1], "avg" the paper's own average column.
"""

from __future__ import annotations

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
