"""What the statistics of `icil_paper.stats` read and return: the checked arrays of a row
(`as_outcomes`, `as_scores`), an `Estimate` with its interval, and the outcomes of a claim's
test (`Verdict`, `Size`; the words printed for them are in `icil_paper.verdict_words`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np


class Verdict(str, Enum):
    """A claim's verdict, stored as its value."""

    HOLDS = "holds"
    DOES_NOT_HOLD = "does not hold"
    INCONCLUSIVE = "inconclusive"
    TOO_FEW_SEEDS = "too few seeds"  # a row has one training seed: nothing is decided
    NOT_RUN = "not run"  # a record the claim reads is missing (the ledger's only)
    __str__, __format__ = str.__str__, str.__format__


class Size(str, Enum):
    """A claim's size read against the paper's effect (`stats.size_decision`)."""

    SMALLER = "smaller than the paper's effect"
    LARGER = "larger than the paper's effect"
    UNDECIDED = "size undecided"
    __str__, __format__ = str.__str__, str.__format__


@dataclass(frozen=True)
class Estimate:
    """A number with its interval, as every table cell and claim shows it."""

    value: float
    low: float
    high: float
    n: int
    """The independent units behind it: training seeds (both rows together for a
    difference), or rows for a correlation across rows."""
    method: str
    """How the interval was computed, e.g. "paired t on 5 seeds 95%"."""
    seeds: tuple[int, ...] = ()
    """Training seeds of each row it reads; empty where not seeded."""
    episodes: int | None = None
    """Episode outcomes (or scored trajectories) behind it, all rows together."""
    se: float | None = None
    """Standard error of a t interval, else None."""
    df: float | None = None
    """Degrees of freedom of a t interval, else None."""
    p_value: float | None = None
    """Two-sided p-value of "the quantity is 0" (differences and correlations)."""
    components: tuple[Estimate, ...] = field(default=())
    """Best of k: the pairwise difference to each other row."""

    def __post_init__(self):
        if not all(math.isfinite(v) for v in (self.value, self.low, self.high)):
            raise ValueError(f"Estimate values must be finite, got {self}")
        if self.low > self.high:
            raise ValueError(f"Estimate interval is reversed: low {self.low} > high {self.high}")

    @property
    def decidable(self) -> bool:
        """False when a row behind it has a single training seed."""
        return not self.seeds or min(self.seeds) >= 2

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready fields."""
        d = {k: getattr(self, k) for k in ("value", "low", "high", "n", "method", "seeds",
                                           "episodes", "se", "df", "p_value")}
        d = {k: list(v) if k == "seeds" else v for k, v in d.items() if v not in (None, ())}
        return d | ({"components": [c.to_dict() for c in self.components]} if self.components
                    else {})

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Estimate:
        """The inverse of `to_dict`."""
        return cls(**{**d, "seeds": tuple(d.get("seeds", ())), "components": tuple(
            cls.from_dict(c) for c in d.get("components", ()))})

    def __str__(self) -> str:
        return f"{self.value:.3g} [{self.low:.3g}, {self.high:.3g}]"


def as_outcomes(outcomes, name: str = "outcomes") -> np.ndarray:
    """Bools or 0/1 shaped (seeds, tasks, episodes) -> float64, or a ValueError naming the
    problem; one episode on several tasks becomes (seeds, 1, tasks), one stratum."""
    try:
        x = np.asarray(outcomes)
    except ValueError as exc:  # ragged nested lists
        raise ValueError(f"{name} must be a full (seeds, tasks, episodes) array: {exc}") from None
    if x.dtype == object or x.dtype != bool and not np.issubdtype(x.dtype, np.number):
        raise ValueError(f"{name} must be a full (seeds, tasks, episodes) array of bools or "
                         f"0/1 numbers, got dtype {x.dtype}")
    if x.ndim != 3 or 0 in x.shape:
        hint = " (wrap one seed's (tasks, episodes) as outcomes[None])" if x.ndim == 2 else ""
        raise ValueError(f"{name} must be shaped (seeds, tasks, episodes) with at least one "
                         f"seed, task and episode, got shape {x.shape}{hint}")
    x = x.astype(np.float64)
    if np.isnan(x).any() or not np.isin(x, (0.0, 1.0)).all():
        raise ValueError(f"{name} must be successes and failures (bools or 0/1, no NaN), got "
                         f"values {np.unique(x)[:5].tolist()}")
    return x.transpose(0, 2, 1) if x.shape[2] == 1 and x.shape[1] > 1 else x


def as_scores(scores, name: str = "scores") -> np.ndarray:
    """Per-trajectory scores (n,) or (seeds, n) -> float64 (seeds, n), or a ValueError."""
    x = np.atleast_2d(np.asarray(scores, dtype=np.float64))
    if x.ndim != 2 or 0 in x.shape or not np.isfinite(x).all():
        raise ValueError(f"{name} must be finite, shaped (trajectories,) or (seeds, "
                         f"trajectories), got shape {np.shape(scores)} (NaN or inf?)")
    return x


def check_level(level: float = 0.95, n_boot: int = 100) -> None:
    """A confidence level in (0, 1) and a bootstrap of at least 100 resamples, or a ValueError."""
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    if int(n_boot) != n_boot or n_boot < 100:
        raise ValueError(f"n_boot must be an integer >= 100, got {n_boot}")
