"""From stored records to a table of numbers with intervals.

    result = assemble(table_spec(preset, "I"), ResultsStore(preset.name))
    result.estimate("icrt+lipvq", "avg")        # Estimate(value, low, high, n, method) or None
    result.outcomes("icrt+lipvq", "avg")        # bools (seeds, tasks, episodes)
    result.frame()                              # a DataFrame: ours, 95% interval, the paper's
    result.markdown()

    result.motion_estimate("icrt+lipvq", "avg", "ldlj")    # Estimate or None
    result.motion_scores("icrt+lipvq", "avg", "ldlj")      # (seeds, episodes), for stats

A success entry holds bools (seeds, tasks, episodes) and `stats.success_rate`; beside them
each episode's LDLJ, SPARC and action jerk (seeds, episodes), NaN where undefined, with the
seed as the unit. A smoothness entry holds per-trajectory least energies (seeds,
trajectories). An entry with a missing record has no estimate ("not run").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from icil_paper import verdict_words
from icil_paper.metrics import MOTION_MEASURES
from icil_paper.records import eval_record, features_record
from icil_paper.results import ResultsStore
from icil_paper.stats import Estimate, score_mean, success_rate
from icil_paper.tables.spec import Entry, TableSpec


@dataclass
class EntryResult:
    """What one entry of a table holds once its records are read."""

    estimate: Estimate | None
    """The number and its 95% interval (None while a unit has no record)."""
    data: np.ndarray | None
    """Success: bools (seeds, tasks, episodes); smoothness: scores (seeds, trajectories)."""
    missing: int
    """Units without a record."""
    extra: dict[str, Any] = field(default_factory=dict)
    """Smoothness entries: standardized scores and estimate, latent scale, view, metrics."""
    scenes: str = "shared"
    """The evaluation design (`Entry.scenes`): "shared" or "per_seed"."""
    motion: dict[str, np.ndarray] = field(default_factory=dict)
    """Success entries: measure -> per-episode values (seeds, episodes), NaN where undefined."""


def _success_entry(entry: Entry, store: ResultsStore) -> EntryResult:
    by_seed: dict[int, list[list[bool]]] = {}
    motion: dict[int, list[dict]] = {}
    missing = 0
    for unit in entry.units:
        record = store.get(*eval_record(unit.run, unit.eval))
        if record is None:
            missing += 1
            continue
        episodes = record["metrics"]["per_episode"]
        by_seed.setdefault(unit.seed_index, []).append([bool(e["success"]) for e in episodes])
        motion.setdefault(unit.seed_index, []).extend(episodes)
    if missing or not by_seed:
        return EntryResult(None, None, missing or len(entry.units))
    data = np.array([by_seed[s] for s in sorted(by_seed)], dtype=bool)  # (S, T, E)
    return EntryResult(success_rate(data), data, 0, scenes=entry.scenes,
                      motion=_motion_values([motion[s] for s in sorted(motion)]))


def _motion_values(by_seed: list[list[dict]]) -> dict[str, np.ndarray]:
    """{measure: (S, episodes)}, NaN where None; empty for a record without motion entries."""
    if not all(m in e for episodes in by_seed for e in episodes for m in MOTION_MEASURES):
        return {}
    return {m: np.array([[np.nan if e[m] is None else float(e[m]) for e in episodes]
                         for episodes in by_seed], dtype=np.float64)
            for m in MOTION_MEASURES}


def filled_motion(values: np.ndarray) -> np.ndarray | None:
    """Motion values (seeds, episodes) with each NaN set to its seed's mean over its defined
    episodes; None when a seed has none defined."""
    x = np.array(values, dtype=np.float64)
    defined = np.isfinite(x)
    if not defined.any(axis=1).all():
        return None
    means = np.nanmean(np.where(defined, x, np.nan), axis=1)  # (S,)
    return np.where(defined, x, means[:, None])


def motion_estimate(values: np.ndarray) -> Estimate | None:
    """Mean motion measure, seed as the unit (`stats.score_mean`; one seed: a bootstrap over
    its defined episodes); None when a seed has none defined."""
    x = filled_motion(values)
    if x is None:
        return None
    if len(x) == 1:
        return score_mean(x[0][np.isfinite(np.asarray(values, dtype=np.float64)[0])])
    return score_mean(x)


def _smoothness_entry(entry: Entry, store: ResultsStore) -> EntryResult:
    per_seed, missing = [], 0
    for unit in sorted(entry.units, key=lambda u: u.seed_index):
        record = store.get(*features_record(unit.run, unit.features))
        if record is None:
            missing += 1
        else:
            per_seed.append(record["metrics"])
    if missing or not per_seed:
        return EntryResult(None, None, missing or len(entry.units))
    data, std = (np.array([m[key] for m in per_seed], dtype=np.float64) for key in (
        "least_energy_per_trajectory", "least_energy_standardized_per_trajectory"))
    return EntryResult(score_mean(data), data, 0,
                      {"standardized": std, "standardized_estimate": score_mean(std),
                       "latent_scale": [m["latent_scale"] for m in per_seed],
                       "view": [m["view"] for m in per_seed], "metrics": per_seed})


@dataclass
class TableResult:
    """A table's entries read from a results store."""

    spec: TableSpec
    entries: dict[tuple[str, str], EntryResult]
    """(row label, column) -> EntryResult."""
    preset: str
    """The preset whose records these are."""

    def entry(self, row: str, column: str) -> EntryResult | None:
        return self.entries.get((row, column))

    def features(self, row: str) -> EntryResult | None:
        """The row's `features` entry once its records are read, else None."""
        entry = self.entry(row, "features")
        return entry if entry is not None and entry.estimate is not None else None

    def estimate(self, row: str, column: str = "avg") -> Estimate | None:
        entry = self.entry(row, column)
        return entry.estimate if entry else None

    def outcomes(self, row: str, column: str = "avg") -> np.ndarray | None:
        entry = self.entry(row, column)
        return entry.data if entry else None

    def motion_scores(self, row: str, column: str = "avg",
                      measure: str = "ldlj") -> np.ndarray | None:
        """A success entry's motion measure (seeds, episodes), `filled_motion`; or None."""
        values = self.entry(row, column).motion.get(measure) if self.entry(row, column) else None
        return None if values is None else filled_motion(values)

    def motion_estimate(self, row: str, column: str = "avg",
                        measure: str = "ldlj") -> Estimate | None:
        """A success entry's `motion_estimate`."""
        values = self.entry(row, column).motion.get(measure) if self.entry(row, column) else None
        return None if values is None else motion_estimate(values)

    def scenes(self, *rows: str, column: str = "avg") -> str:
        """"per_seed" when every one of `rows` gives seed k scene set k, else "shared"."""
        designs = {c.scenes for r in rows if (c := self.entry(r, column)) is not None}
        return "per_seed" if designs == {"per_seed"} else "shared"

    @property
    def complete(self) -> bool:
        return all(c.estimate is not None for c in self.entries.values())

    @property
    def missing(self) -> int:
        return sum(c.missing for c in self.entries.values())

    def frame(self, paper: bool = True):
        """A long DataFrame: row, column, ours, low, high, n, paper (the paper's number)."""
        import pandas as pd

        rows = []
        for row in self.spec.rows:
            for column in self.spec.columns:
                entry = self.entries.get((row.label, column))
                est = entry.estimate if entry else None
                rows.append({"row": row.label, "column": column,
                             "ours": est.value if est else None,
                             "low": est.low if est else None,
                             "high": est.high if est else None,
                             "n": est.n if est else None,
                             "status": ("n/a" if entry is None else
                                        "ok" if est else verdict_words.MISSING),
                             **({"paper": row.paper.get(column)} if paper else {})})
        return pd.DataFrame(rows)

    def markdown(self, digits: int = 2, paper: bool = True) -> str:
        """A GitHub-flavoured markdown table, one row per table row: each column as
        `ours [low, high]`, the paper's number beside it."""
        header = ["", *(name for column in self.spec.columns
                        for name in (column, f"{column} (paper)")[:1 + paper])]
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        for row in self.spec.rows:
            cells = [row.label]
            for column in self.spec.columns:
                cells.append(format_entry(self.entries.get((row.label, column)), digits))
                if paper:
                    value = row.paper.get(column)
                    places = digits + 1 if column == "avg" else digits  # as the paper prints
                    cells.append("" if value is None else f"{value:.{places}f}")
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        return {"table": self.spec.id, "title": self.spec.title, "preset": self.preset,
                "measure": self.spec.measure, "columns": list(self.spec.columns),
                "rows": [{"row": row.label, "paper": dict(row.paper), "entries": {
                    column: (None if (c := self.entries.get((row.label, column))) is None
                             or c.estimate is None else c.estimate.to_dict())
                    for column in self.spec.columns}} for row in self.spec.rows]}


def unbroken(text: str) -> str:
    """`text` with non-breaking spaces, so that a narrow column keeps it on one line."""
    return text.replace(" ", "\u00a0")


def format_entry(entry: EntryResult | None, digits: int = 2) -> str:
    """`0.53 [0.41, 0.64]`, `not run` or `n/a`."""
    if entry is None:
        return "n/a"
    est = entry.estimate
    if est is None:
        return verdict_words.MISSING
    return f"{est.value:.{digits}f} [{est.low:.{digits}f}, {est.high:.{digits}f}]"


def format_difference(est: Estimate, digits: int = 3) -> str:
    """`+0.053 [-0.012, +0.118]`: a signed difference with its interval."""
    return f"{est.value:+.{digits}f} [{est.low:+.{digits}f}, {est.high:+.{digits}f}]"


def assemble(spec: TableSpec, store: ResultsStore) -> TableResult:
    """Read every entry of `spec` from `store` (nothing is computed)."""
    entries = {(row.label, column): (_smoothness_entry if entry.units[0].features is not None
                                   else _success_entry)(entry, store)
             for row in spec.rows for column, entry in row.entries.items()}
    return TableResult(spec, entries, store.preset)
