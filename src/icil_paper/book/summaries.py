"""What the chapters show of a study's records: seed averages and intervals.

    from icil_paper.book.studies import tokenizer_study
    from icil_paper.book.summaries import SeedRecords
    seeds = SeedRecords(tokenizer_study(preset, store))    # {label: [metrics per seed]}
    seeds.mean("lipvq", "usage")                            # mean over training seeds
    seeds.with_interval("lipvq", "least_energy")            # "0.012 [0.01, 0.014]"
    seeds.seed_means()                                      # one row of means per label
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from icil_paper import stats


class SeedRecords:
    """A study's records, {label: [metrics of each training seed]}, summarised over seeds."""

    def __init__(self, records: Mapping[str, Sequence[Mapping[str, Any]]]):
        self.records = {label: list(ms) for label, ms in records.items()}
        empty = [label for label, ms in self.records.items() if not ms]
        if empty:
            raise ValueError(f"no seed's record for {empty}: run the study first")

    @property
    def n_seeds(self) -> int:
        """Training seeds of the first label (every label of a study has the same)."""
        return len(next(iter(self.records.values()))) if self.records else 0

    def mean(self, label: str, key: str) -> float | None:
        """The mean of `key` over the seeds that recorded it (None where none did)."""
        values = [m[key] for m in self.records[label] if m.get(key) is not None]
        return float(np.mean(values)) if values else None

    def per_level(self, label: str) -> str | None:
        """Residual VQ: the codes each level uses, mean over seeds ("8 / 7"); None otherwise."""
        levels = [m["codes_used_per_level"] for m in self.records[label]
                  if m.get("codes_used_per_level")]
        return " / ".join(f"{v:.0f}" for v in np.mean(levels, axis=0)) if levels else None

    def scores(self, label: str, key: str) -> np.ndarray:
        """(seeds, trajectories) per-trajectory scores of `key` (`<key>_per_trajectory`)."""
        return np.array([m[f"{key}_per_trajectory"] for m in self.records[label]], dtype=float)

    def with_interval(self, label: str, key: str, digits: int = 3) -> str:
        """The mean score with its 95% interval (`stats.score_mean`), as text."""
        est = stats.score_mean(self.scores(label, key))
        return f"{est.value:.{digits}g} [{est.low:.{digits}g}, {est.high:.{digits}g}]"

    def seed_means(self) -> dict[str, dict[str, Any]]:
        """One row per label: the mean over seeds of every number, seed 0's value otherwise."""
        rows = {}
        for label, ms in self.records.items():
            first = ms[0]
            rows[label] = {k: (float(np.mean([m[k] for m in ms]))
                               if isinstance(v, (int, float))
                               else v) for k, v in first.items()}
        return rows
