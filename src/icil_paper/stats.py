"""Statistics behind every table and claim: success rates with intervals, paired
differences, rank correlations, and the rule that turns an interval into a verdict.

    from icil_paper.stats import paired_difference, success_rate, verdict
    row = success_rate(outcomes)               # outcomes: bools (seeds, tasks, episodes)
    row.value, row.low, row.high               # mean success and its 95% interval
    diff = paired_difference(lipvq, bc)        # same tasks and episodes in both rows
    verdict(diff, direction=+1)                # "holds", "does not hold" or "inconclusive"

Success rate of a row. Outcomes are shaped (seeds, tasks, episodes): one bool per
evaluation episode. The row's value is the mean over tasks of each task's success rate,
averaged over seeds, so every task weighs the same. Its 95% interval is

- one seed, one task: the Wilson score interval over the episodes;
- one seed, several tasks: a stratified bootstrap: episodes are resampled with replacement
  within each task, the row's value recomputed, and the 2.5th and 97.5th percentiles of
  2000 such values taken;
- several seeds: a hierarchical bootstrap: seeds are resampled with replacement, then
  episodes within each task, and the percentiles taken as above. It carries both the
  spread between training seeds and the luck of the evaluation episodes.

With a single episode per task there is nothing to resample within a task, so the tasks'
episodes are pooled into one stratum (for one seed: a Wilson interval over all of them).

A bootstrap interval is the percentile interval of the resampled values, widened where
needed to hold the point value itself (a percentile interval can miss it when the
resamples are very skewed), and never narrower than the Wilson interval of all the row's
episodes pooled: a bootstrap cannot draw a success that never happened, so a row that
failed (or succeeded) every episode would otherwise get the point interval [0, 0]
(or [1, 1]), as if its rate were known exactly.

Episode i of task t is the same scene in every seed and every row (evaluation episodes are
fixed by the evaluation seed alone), so one bootstrap draw resamples the same episode
indices for all seeds, and for both rows of a paired difference. A paired difference
therefore compares the two rows on the same resampled scenes, which removes the part of
the spread that comes from some scenes being harder than others.

The verdict rule (quoted in the claims chapter). Each claim of the paper is written as a
quantity, a direction and a threshold: "LipVQ beats LFQ" is the difference LipVQ - LFQ,
claimed to be above 0. From our 95% interval of that quantity:

- the claim **holds** when the whole interval lies beyond the threshold in the claimed
  direction (for "above 0": its lower end is above 0);
- it **does not hold** when the whole interval lies on the other side of the threshold
  (its upper end is below 0): our data show the opposite;
- it is **inconclusive** otherwise: the interval contains the threshold (or touches it),
  so our data cannot tell the two apart at this number of seeds and episodes.

"Does not hold" is a strong statement (the opposite was measured), "inconclusive" is not
evidence against the paper: more seeds or episodes narrow the interval and may settle it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

Z_95 = 1.959963984540054
"""The standard normal quantile of a two-sided 95% interval."""

Verdict = Literal["holds", "does not hold", "inconclusive"]


@dataclass(frozen=True)
class Estimate:
    """A number with its confidence interval, as every table cell and claim shows it."""

    value: float
    """The point estimate (a success rate, a difference of rates, a correlation)."""
    low: float
    """Lower end of the interval."""
    high: float
    """Upper end of the interval."""
    n: int
    """The sample behind it: episode outcomes for a success rate or a difference (all seeds,
    tasks and episodes, both rows together for a difference), rows for a correlation."""
    method: str
    """How the interval was computed, e.g. "wilson 95%" or "hierarchical bootstrap 95%"."""

    def __post_init__(self):
        for name in ("value", "low", "high"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"Estimate.{name} must be finite, got {getattr(self, name)}")
        if self.low > self.high:
            raise ValueError(f"Estimate interval is reversed: low {self.low} > high {self.high}")

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready fields: value, low, high, n, method."""
        d = asdict(self)
        d.update(value=float(self.value), low=float(self.low), high=float(self.high),
                 n=int(self.n))
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Estimate:
        """The inverse of `to_dict`."""
        return cls(value=float(d["value"]), low=float(d["low"]), high=float(d["high"]),
                   n=int(d["n"]), method=str(d["method"]))

    def __str__(self) -> str:
        return f"{self.value:.3g} [{self.low:.3g}, {self.high:.3g}]"


def wilson_interval(successes: int, n: int, z: float = Z_95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (95% by default); (0, 1) for n = 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # The interval always holds p (rounding alone can leave 1 - 1e-16 for k = n).
    return max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half))


# ---------------------------------------------------------------------------- input checks

def _z(level: float) -> float:
    """The standard normal quantile of a two-sided interval at `level`."""
    if level == 0.95:
        return Z_95
    from scipy.stats import norm

    return float(norm.ppf(0.5 + level / 2))


def _check_level(level: float) -> None:
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level}")


def _check_n_boot(n_boot: int) -> None:
    if int(n_boot) != n_boot or n_boot < 100:
        raise ValueError(f"n_boot must be an integer >= 100, got {n_boot}")


def _as_outcomes(outcomes, name: str = "outcomes") -> np.ndarray:
    """Bools or 0/1 numbers shaped (seeds, tasks, episodes) -> float64 array of 0 and 1.

    With one episode per task (and several tasks), resampling episodes within each task
    cannot vary anything (there is only one to draw), so the interval would be a point;
    the tasks' single episodes are then resampled together as one stratum (returned as
    (seeds, 1, tasks)), which keeps the row's value and gives the episodes' luck a spread.
    """
    try:
        x = np.asarray(outcomes)
    except ValueError as exc:  # ragged nested lists
        raise ValueError(f"{name} must be a full (seeds, tasks, episodes) array; every seed "
                         f"needs the same tasks and every task the same number of episodes "
                         f"(got ragged input: {exc})") from None
    if x.dtype == object:
        raise ValueError(f"{name} must be a full (seeds, tasks, episodes) array of bools; got "
                         "ragged or non-numeric input")
    if x.ndim != 3:
        hint = " (wrap one seed's (tasks, episodes) array as outcomes[None])" if x.ndim == 2 else ""
        raise ValueError(f"{name} must be shaped (seeds, tasks, episodes), got shape "
                         f"{x.shape}{hint}")
    if 0 in x.shape:
        raise ValueError(f"{name} must have at least one seed, task and episode, got shape "
                         f"{x.shape}")
    if x.dtype == bool:
        return _pool_single_episodes(x.astype(np.float64))
    if not np.issubdtype(x.dtype, np.number):
        raise ValueError(f"{name} must hold bools or 0/1 numbers, got dtype {x.dtype}")
    x = x.astype(np.float64)
    if np.isnan(x).any():
        raise ValueError(f"{name} contain NaN: every episode needs an outcome (drop an "
                         "unfinished seed or task from every row alike)")
    if not np.isin(x, (0.0, 1.0)).all():
        raise ValueError(f"{name} must be successes and failures (bools or 0/1), got values "
                         f"{np.unique(x)[:5].tolist()}...")
    return _pool_single_episodes(x)


def _pool_single_episodes(x: np.ndarray) -> np.ndarray:
    """(S, T, 1) with T > 1 -> (S, 1, T): see `_as_outcomes`."""
    return x.transpose(0, 2, 1) if x.shape[2] == 1 and x.shape[1] > 1 else x


def _as_scores(scores, name: str = "scores") -> np.ndarray:
    """Per-trajectory scores (n,) or (seeds, n) -> float64 array (seeds, n)."""
    try:
        x = np.asarray(scores, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a full numeric array shaped (trajectories,) or "
                         f"(seeds, trajectories): {exc}") from None
    if x.ndim == 1:
        x = x[None]
    if x.ndim != 2 or 0 in x.shape:
        raise ValueError(f"{name} must be shaped (trajectories,) or (seeds, trajectories) "
                         f"with at least one trajectory, got shape {np.shape(scores)}")
    if not np.isfinite(x).all():
        raise ValueError(f"{name} contain NaN or inf")
    return x


# ------------------------------------------------------------------------------ resampling

def _seed_weights(rng: np.random.Generator, n_boot: int, n_seeds: int) -> np.ndarray:
    """(n_boot, S): how often each seed is drawn in a resample of S seeds, divided by S."""
    if n_seeds == 1:
        return np.ones((n_boot, 1))
    return rng.multinomial(n_seeds, np.full(n_seeds, 1.0 / n_seeds), size=n_boot) / n_seeds


def _episode_indices(rng: np.random.Generator, n_boot: int, n_tasks: int,
                     n_episodes: int) -> np.ndarray:
    """(n_boot, T, E): episode indices resampled with replacement within each task."""
    return rng.integers(0, n_episodes, size=(n_boot, n_tasks, n_episodes))


def _resampled_rates(x: np.ndarray, seed_w: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Row values of each resample: x (S, T, E), seed_w (B, S), idx (B, T, E) -> (B,)."""
    by_seed = np.einsum("bs,ste->bte", seed_w, x)  # (B, T, E): seed-averaged outcomes
    return np.take_along_axis(by_seed, idx, axis=2).mean(axis=(1, 2))


def _percentiles(samples: np.ndarray, level: float) -> tuple[float, float]:
    alpha = 100 * (1 - level) / 2
    low, high = np.percentile(samples, [alpha, 100 - alpha])
    return float(low), float(high)


def success_rate_samples(outcomes, *, n_boot: int = 2000, rng_seed: int = 0) -> np.ndarray:
    """Bootstrap resamples of a row's success rate, shaped (n_boot,).

    outcomes: bools (seeds, tasks, episodes). Seeds are resampled with replacement (when
    there are several), then episodes within each task, the same episode indices for every
    seed (episode i is the same scene in each). These are the samples `success_rate`
    takes its bootstrap interval from; `rank_correlation_interval` combines them across rows.
    """
    x = _as_outcomes(outcomes)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    S, T, E = x.shape
    idx = _episode_indices(rng, n_boot, T, E)
    return _resampled_rates(x, _seed_weights(rng, n_boot, S), idx)


def success_rate(outcomes, *, n_boot: int = 2000, rng_seed: int = 0,
                 level: float = 0.95) -> Estimate:
    """A row's success rate with its interval (see the module docstring for the method).

    outcomes: bools (seeds, tasks, episodes), full (no missing episodes). The value is the
    mean over seeds of the mean over tasks of each task's success rate. One seed and one
    task: Wilson interval; one seed, several tasks: stratified bootstrap over episodes;
    several seeds: hierarchical bootstrap over seeds, then episodes (a bootstrap interval
    covers at least the pooled episodes' Wilson interval). Deterministic given `rng_seed`.
    """
    x = _as_outcomes(outcomes)
    _check_level(level)
    S, T, E = x.shape
    value = float(x.mean())
    pct = f"{100 * level:g}%"
    if S == 1 and T == 1:
        low, high = wilson_interval(int(x.sum()), E, _z(level))
        return Estimate(value, low, high, x.size, f"wilson {pct}")
    samples = success_rate_samples(x, n_boot=n_boot, rng_seed=rng_seed)
    low, high = _percentiles(samples, level)
    pooled_low, pooled_high = wilson_interval(int(round(x.sum())), x.size, _z(level))
    method = "stratified bootstrap" if S == 1 else "hierarchical bootstrap"
    return Estimate(value, min(low, value, pooled_low), max(high, value, pooled_high),
                    x.size, f"{method} {pct}")


def paired_difference(a, b, *, n_boot: int = 2000, rng_seed: int = 0,
                      level: float = 0.95) -> Estimate:
    """Success rate of row `a` minus that of row `b`, on the same episodes, with its interval.

    a: bools (seeds_a, tasks, episodes), b: bools (seeds_b, tasks, episodes); the two rows
    must share tasks and episodes (episode i of task t the same scene in both), their seed
    counts may differ. Each bootstrap draw resamples each row's seeds independently and one
    set of episode indices used for both rows, so scene difficulty cancels out of the
    difference. The interval is the percentile interval of the resampled differences.
    """
    xa, xb = _as_outcomes(a, "a"), _as_outcomes(b, "b")
    if xa.shape[1:] != xb.shape[1:]:
        raise ValueError("paired rows need the same (tasks, episodes): a has "
                         f"{xa.shape[1:]}, b has {xb.shape[1:]} (shapes {xa.shape} and "
                         f"{xb.shape})")
    _check_level(level)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    _, T, E = xa.shape
    idx = _episode_indices(rng, n_boot, T, E)
    diffs = (_resampled_rates(xa, _seed_weights(rng, n_boot, len(xa)), idx)
             - _resampled_rates(xb, _seed_weights(rng, n_boot, len(xb)), idx))
    value = float(xa.mean() - xb.mean())
    low, high = _percentiles(diffs, level)
    return Estimate(value, min(low, value), max(high, value), xa.size + xb.size,
                    f"paired bootstrap {100 * level:g}%")


def mean_samples(scores, *, n_boot: int = 2000, rng_seed: int = 0,
                 idx: np.ndarray | None = None) -> np.ndarray:
    """Bootstrap resamples of the mean of per-trajectory scores (e.g. least energy), (n_boot,).

    scores: (trajectories,) or (seeds, trajectories), the same held-out trajectories for
    every seed. Seeds are resampled (when several), then trajectories, the same indices for
    every seed. `idx` (n_boot, trajectories) fixes the trajectory indices (to share them
    between rows scored on the same trajectories).
    """
    x = _as_scores(scores)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    S, N = x.shape
    if idx is None:
        idx = rng.integers(0, N, size=(n_boot, N))
    elif idx.shape != (n_boot, N):
        raise ValueError(f"idx must be shaped (n_boot, trajectories) = {(n_boot, N)}, "
                         f"got {idx.shape}")
    return _resampled_rates(x[:, None, :], _seed_weights(rng, n_boot, S), idx[:, None, :])


# ----------------------------------------------------------------------------- correlation

def _spearman_columns(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Spearman correlation of x[:, j] with y[:, j] for each column j; 0 where a column ties."""
    from scipy.stats import rankdata

    rx = rankdata(x, axis=0)
    ry = rankdata(y, axis=0)
    rx = rx - rx.mean(axis=0)
    ry = ry - ry.mean(axis=0)
    den = np.sqrt((rx**2).sum(axis=0) * (ry**2).sum(axis=0))
    num = (rx * ry).sum(axis=0)
    out = np.zeros(x.shape[1])
    ok = den > 0
    out[ok] = num[ok] / den[ok]
    return np.clip(out, -1.0, 1.0)


def rank_correlation_interval(x_samples, y_samples, *, x=None, y=None,
                              level: float = 0.95) -> Estimate:
    """Spearman correlation across rows of two quantities, with a percentile interval.

    x_samples, y_samples: (rows, n_boot) bootstrap resamples of each row's two quantities
    (e.g. `mean_samples` of its smoothness scores and `success_rate_samples` of its
    outcomes); column j is one joint resample of every row. x, y: (rows,) point values
    (default: the mean of each row's samples). The value is the Spearman correlation of the
    point values; the interval the percentiles of the correlations of the resamples. A
    resample in which all rows tie on one quantity orders nothing and counts as 0.
    """
    xs = np.asarray(x_samples, dtype=np.float64)
    ys = np.asarray(y_samples, dtype=np.float64)
    if xs.ndim != 2 or xs.shape != ys.shape:
        raise ValueError("x_samples and y_samples must both be shaped (rows, n_boot), got "
                         f"{xs.shape} and {ys.shape}")
    if xs.shape[0] < 3:
        raise ValueError(f"a rank correlation across rows needs at least 3 rows, got {xs.shape[0]}")
    if not (np.isfinite(xs).all() and np.isfinite(ys).all()):
        raise ValueError("x_samples and y_samples must be finite")
    _check_level(level)
    px = xs.mean(axis=1) if x is None else np.asarray(x, dtype=np.float64)
    py = ys.mean(axis=1) if y is None else np.asarray(y, dtype=np.float64)
    if px.shape != (len(xs),) or py.shape != (len(xs),):
        raise ValueError(f"x and y must be shaped (rows,) = ({len(xs)},), got {px.shape} and "
                         f"{py.shape}")
    value = float(_spearman_columns(px[:, None], py[:, None])[0])
    low, high = _percentiles(_spearman_columns(xs, ys), level)
    return Estimate(value, min(low, value), max(high, value), len(xs),
                    f"spearman, joint bootstrap {100 * level:g}%")


def score_success_correlation(scores: Sequence, outcomes: Sequence, *, n_boot: int = 2000,
                              rng_seed: int = 0, paired: bool = True,
                              level: float = 0.95) -> Estimate:
    """Spearman correlation across rows of a per-trajectory score and success, with interval.

    scores: per row, its per-trajectory scores, (trajectories,) or (seeds, trajectories);
    outcomes: per row, its bools (seeds, tasks, episodes). For "smoother tokenizers succeed
    more", pass each row's least energies and outcomes: a negative correlation (lower
    energy, higher success) supports the claim. With `paired` (the default) every row must
    be scored on the same trajectories and evaluated on the same tasks and episodes, and
    each joint resample uses the same trajectory and episode indices for all rows; with
    `paired=False` each row is resampled on its own.
    """
    if len(scores) != len(outcomes):
        raise ValueError(f"one score array and one outcome array per row: got {len(scores)} "
                         f"score arrays and {len(outcomes)} outcome arrays")
    _check_n_boot(n_boot)
    xs = [_as_scores(s, f"scores[{i}]") for i, s in enumerate(scores)]
    ys = [_as_outcomes(o, f"outcomes[{i}]") for i, o in enumerate(outcomes)]
    rng = np.random.default_rng(rng_seed)
    if paired:
        if len({s.shape[1] for s in xs}) > 1 or len({o.shape[1:] for o in ys}) > 1:
            raise ValueError(
                "paired rows must share trajectories and (tasks, episodes): got trajectory "
                f"counts {[s.shape[1] for s in xs]} and (tasks, episodes) "
                f"{[o.shape[1:] for o in ys]}; pass paired=False to resample rows separately")
        traj_idx = rng.integers(0, xs[0].shape[1], size=(n_boot, xs[0].shape[1]))
        ep_idx = _episode_indices(rng, n_boot, *ys[0].shape[1:])
    x_samples, y_samples = [], []
    for s, o in zip(xs, ys, strict=True):
        t_idx = traj_idx if paired else rng.integers(0, s.shape[1], size=(n_boot, s.shape[1]))
        e_idx = ep_idx if paired else _episode_indices(rng, n_boot, *o.shape[1:])
        x_samples.append(_resampled_rates(s[:, None, :], _seed_weights(rng, n_boot, len(s)),
                                          t_idx[:, None, :]))
        y_samples.append(_resampled_rates(o, _seed_weights(rng, n_boot, len(o)), e_idx))
    return rank_correlation_interval(
        np.stack(x_samples), np.stack(y_samples), x=np.array([s.mean() for s in xs]),
        y=np.array([o.mean() for o in ys]), level=level)


# --------------------------------------------------------------------------------- verdict

def verdict(estimate: Estimate, direction: int = +1, threshold: float = 0.0) -> Verdict:
    """"holds", "does not hold" or "inconclusive" for a claim about `estimate`.

    direction +1: the paper claims the quantity is above `threshold`; -1: below it. Holds
    when the whole interval lies strictly beyond the threshold in the claimed direction,
    does not hold when it lies strictly on the other side, inconclusive otherwise (the
    interval contains or touches the threshold).
    """
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 (claimed above the threshold) or -1 (below), "
                         f"got {direction}")
    low, high = estimate.low, estimate.high
    if direction == -1:
        low, high, threshold = -high, -low, -threshold
    if low > threshold:
        return "holds"
    if high < threshold:
        return "does not hold"
    return "inconclusive"


def paired_score_difference(a, b, *, n_boot: int = 2000, rng_seed: int = 0,
                            level: float = 0.95) -> Estimate:
    """Mean per-trajectory score of row `a` minus that of row `b`, with a paired interval.

    a, b: (trajectories,) or (seeds, trajectories), both scored on the same held-out
    trajectories (seed counts may differ). Each draw resamples each row's seeds on its own
    and one set of trajectory indices for both rows, so trajectory difficulty cancels.
    """
    xa, xb = _as_scores(a, "a"), _as_scores(b, "b")
    if xa.shape[1] != xb.shape[1]:
        raise ValueError(f"paired rows need the same trajectories: a has {xa.shape[1]}, "
                         f"b has {xb.shape[1]}")
    _check_level(level)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    idx = rng.integers(0, xa.shape[1], size=(n_boot, xa.shape[1]))
    diffs = (mean_samples(xa, n_boot=n_boot, rng_seed=rng_seed + 1, idx=idx)
             - mean_samples(xb, n_boot=n_boot, rng_seed=rng_seed + 2, idx=idx))
    value = float(xa.mean() - xb.mean())
    low, high = _percentiles(diffs, level)
    return Estimate(value, min(low, value), max(high, value), xa.size + xb.size,
                    f"paired bootstrap {100 * level:g}%")


def score_mean(scores, *, n_boot: int = 2000, rng_seed: int = 0,
               level: float = 0.95) -> Estimate:
    """The mean of per-trajectory scores, (trajectories,) or (seeds, trajectories), with a
    bootstrap interval over seeds and trajectories."""
    x = _as_scores(scores)
    _check_level(level)
    low, high = _percentiles(mean_samples(x, n_boot=n_boot, rng_seed=rng_seed), level)
    value = float(x.mean())
    return Estimate(value, min(low, value), max(high, value), x.size,
                    f"bootstrap {100 * level:g}%")


def paired_margin(a, others: Sequence, *, n_boot: int = 2000, rng_seed: int = 0,
                  level: float = 0.95) -> Estimate:
    """Row `a`'s success rate minus the best of `others`, all on the same episodes.

    For claims like "LipVQ-VAE is the best tokenizer": above 0 means `a` beats every other
    row. a and each of `others`: bools (seeds, tasks, episodes) with the same (tasks,
    episodes). Each draw resamples every row's seeds on its own and one set of episode
    indices for all rows; the margin of the draw is a's rate minus the largest other rate.
    """
    xa = _as_outcomes(a, "a")
    xs = [_as_outcomes(o, f"others[{i}]") for i, o in enumerate(others)]
    if not xs:
        raise ValueError("paired_margin needs at least one other row")
    for i, x in enumerate(xs):
        if x.shape[1:] != xa.shape[1:]:
            raise ValueError(f"paired rows need the same (tasks, episodes): a has "
                             f"{xa.shape[1:]}, others[{i}] has {x.shape[1:]}")
    _check_level(level)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    idx = _episode_indices(rng, n_boot, *xa.shape[1:])
    rates = [_resampled_rates(x, _seed_weights(rng, n_boot, len(x)), idx) for x in [xa, *xs]]
    margins = rates[0] - np.max(rates[1:], axis=0)
    value = float(xa.mean() - max(x.mean() for x in xs))
    low, high = _percentiles(margins, level)
    return Estimate(value, min(low, value), max(high, value),
                    xa.size + sum(x.size for x in xs), f"paired bootstrap {100 * level:g}%")


def paired_score_margin(a, others: Sequence, *, n_boot: int = 2000, rng_seed: int = 0,
                        level: float = 0.95) -> Estimate:
    """Row `a`'s mean score minus the lowest mean score of `others`, on the same trajectories.

    For claims like "LipVQ-VAE is the smoothest" (lower least energy is smoother): below 0
    means `a` scores lower than every other row. Arrays as in `paired_score_difference`.
    """
    xa = _as_scores(a, "a")
    xs = [_as_scores(o, f"others[{i}]") for i, o in enumerate(others)]
    if not xs:
        raise ValueError("paired_score_margin needs at least one other row")
    if any(x.shape[1] != xa.shape[1] for x in xs):
        raise ValueError("paired rows need the same trajectories: got "
                         f"{[xa.shape[1], *(x.shape[1] for x in xs)]}")
    _check_level(level)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    idx = rng.integers(0, xa.shape[1], size=(n_boot, xa.shape[1]))
    means = [mean_samples(x, n_boot=n_boot, rng_seed=rng_seed + 1 + i, idx=idx)
             for i, x in enumerate([xa, *xs])]
    margins = means[0] - np.min(means[1:], axis=0)
    value = float(xa.mean() - min(x.mean() for x in xs))
    low, high = _percentiles(margins, level)
    return Estimate(value, min(low, value), max(high, value),
                    xa.size + sum(x.size for x in xs), f"paired bootstrap {100 * level:g}%")
