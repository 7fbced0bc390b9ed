"""A table as data: rows x columns -> entries, each entry a set of (run, evaluation) units.

    TableSpec ── rows: Row(label, entries: {column: Entry}, paper: {column: number})
                                              │
                              Entry ── units: Unit(seed_index, run: RunSpec, eval: EvalSpec
                                                  or None, features: FeatureSpec or None)

A unit is one trained policy and one measurement on it: an evaluation or, for the
smoothness table, latent features of held-out trajectories. Units are keyed by content, so
a policy that several tables name is trained once (`cells.plan`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from icil_paper.runspec import EvalSpec, FeatureSpec, RunSpec


@dataclass(frozen=True)
class Unit:
    """One trained policy and one measurement on it."""

    seed_index: int
    """Which of the row's training seeds (0 .. seeds - 1)."""
    run: RunSpec
    """The training run."""
    eval: EvalSpec | None = None
    """An evaluation of it, or None."""
    features: FeatureSpec | None = None
    """Latent features of it, or None."""


@dataclass(frozen=True)
class Entry:
    """The units one number of a table aggregates."""

    units: tuple[Unit, ...]
    """Every (seed, task) unit of the entry."""

    @property
    def seeds(self) -> int:
        return len({u.seed_index for u in self.units})

    @property
    def scenes(self) -> str:
        """"per_seed" when training seed k is evaluated on scene set k, else "shared"."""
        by_seed: dict[int, set] = {}
        for u in self.units:
            if u.eval is not None:
                by_seed.setdefault(u.seed_index, set()).add(u.eval.seed)
        return "per_seed" if len({frozenset(v) for v in by_seed.values()}) > 1 else "shared"


@dataclass(frozen=True)
class Row:
    """One row of a table: a policy (+ tokenizer, or a variant) and its entries by column."""

    label: str
    """Row name as the paper prints it (`icrt+lipvq`, `bc_transformer`, `2^10`, ...)."""
    entries: Mapping[str, Entry]
    """Column -> entry; a column missing here has no unit in our stand-in (shown as n/a)."""
    paper: Mapping[str, float] = field(default_factory=dict)
    """The paper's numbers of this row by column (empty where the paper has none)."""


@dataclass(frozen=True)
class TableSpec:
    """One table or figure of the paper."""

    id: str
    """`I` .. `VII`, `fig5`, `prompt`, or our own results' names (`analysis`, `icrt`, ...)."""
    title: str
    """The caption, as the paper words it, with our stand-in named."""
    columns: tuple[str, ...]
    """Column names in display order (the last is usually `avg`)."""
    rows: tuple[Row, ...]
    """The rows in the paper's order."""
    measure: str = "success"
    """`success` (higher is better) or `smoothness` (least energy, lower is smoother)."""
    note: str = ""
    """How this table is computed here, and what stands in for what."""
    beside: tuple[str, ...] = ()
    """Columns measured but not shown among `columns` (`features`: codebook use)."""

    def row(self, label: str) -> Row:
        for row in self.rows:
            if row.label == label:
                return row
        raise KeyError(f"table {self.id} has no row {label!r}; rows: "
                       f"{', '.join(r.label for r in self.rows)}")

    def units(self) -> list[Unit]:
        """Every unit of every entry (with repeats where entries share units)."""
        return [u for row in self.rows for entry in row.entries.values() for u in entry.units]
