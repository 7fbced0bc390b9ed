"""Statistics behind every table and claim, with the training seed as the unit.

    row = success_rate(outcomes)                          # bools (seeds, tasks, episodes)
    diff = paired_difference(a, b, scenes="per_seed")     # a - b with its 95% interval
    verdict(diff, direction=+1)                           # holds, does not hold, ...

- Intervals: the t interval on per-seed values; a difference, the paired t where seed k of
  both rows plays scene set k, else Welch's t. One seed: episode noise only, no verdict.
- Verdict: the 95% interval against 0; best of k, an intersection-union test (Berger 1982).
- Multiplicity: the graphical procedure of Bretz et al. (2009), weighted Holm by default.
- Seeds in stages: Lan-DeMets (1983) O'Brien-Fleming-type spending, repeated p-values
  (Jennison and Turnbull 2000, ch. 9), the graph at every look (Maurer and Bretz 2013).
- Planning: (t_{1-a/2} + t_{power}) se (Colas et al. 2018); episodes per task by two-stage
  sampling (Cochran 1977, 10.6).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Literal

import numpy as np
from scipy import stats as sps
from scipy.optimize import brentq
from scipy.special import ndtr, ndtri

from icil_paper.estimates import Estimate, Size, Verdict, as_outcomes, as_scores, check_level

ALPHA, POWER = 0.05, 0.8  # the tests' level (95% intervals, 5% familywise); planned power


def wilson_interval(successes: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion; (0, 1) for n = 0."""
    if n <= 0:
        return 0.0, 1.0
    ci = sps.binomtest(int(successes), int(n)).proportion_ci(level, method="wilson")
    p = successes / n  # the interval holds p (rounding can leave 1 - 1e-16 at k = n)
    return max(0.0, min(p, ci.low)), min(1.0, max(p, ci.high))


# ------------------------------------------------------------------------ per-seed variance
_per_seed = lambda x: x.reshape(len(x), -1).mean(axis=1)  # (seeds, ...) -> (seeds,)


def _variance(xs: list[np.ndarray], kind: str) -> float:
    """Variance of per-seed values (xs: one row) or differences (two rows, common seeds); if
    equal to rounding, a seed's episode noise sum_t p~(1 - p~) / (E T^2) (Agresti-Coull p~)."""
    n = min(len(x) for x in xs)
    v = _per_seed(xs[0][:n]) - (_per_seed(xs[1][:n]) if len(xs) > 1 else 0)
    if not np.allclose(v, v[0], rtol=1e-9, atol=1e-12):
        return float(np.var(v, ddof=1))
    p = [(x[:n].sum(axis=(0, 2)) + 2) / (n * x.shape[2] + 4) for x in xs]
    return (sum(float((q * (1 - q)).sum()) for q in p) / (xs[0].shape[2] * xs[0].shape[1] ** 2)
            if kind == "success" else 0.0)


def seed_variance(data, kind: Literal["success", "score"] = "success", other=None):
    """The variance of a row's per-seed values, or with `other` of the per-seed differences
    over the seeds both rows have (what the paired t reads); None below two seeds."""
    xs = [as_outcomes(x) if kind == "success" else as_scores(x)[:, None]
          for x in (data, other) if x is not None]
    return None if min(len(x) for x in xs) < 2 else _variance(xs, kind)


def paired_variance_parts(a, b) -> tuple[float, float]:
    """(episode part at one episode a task, seed-by-row part) of Var(d_k) for rows playing
    the same scenes: sum_t s^2_kt / T^2 of the paired episode differences, and the rest."""
    xa, xb = as_outcomes(a, "a"), as_outcomes(b, "b")
    n = min(len(xa), len(xb))
    if xa.shape[1:] != xb.shape[1:] or n < 2 or xa.shape[2] < 2:
        raise ValueError(f"variance parts need 2 rows alike, 2 seeds, 2 episodes: {xa.shape}")
    d = xa[:n] - xb[:n]
    episode = float(d.var(axis=2, ddof=1).sum(axis=1).mean() / d.shape[1] ** 2)
    return episode, max(float(_per_seed(d).var(ddof=1)) - episode / d.shape[2], 0.0)


# ------------------------------------------------------------------------------ estimates
def _t(value, se, df, level, method, bounds=(-math.inf, math.inf), **fields) -> Estimate:
    """value +- t se, clipped to `bounds`, with the two-sided t-test p-value of 0."""
    half = sps.t.isf((1 - level) / 2, df) * se
    p = float(2 * sps.t.sf(abs(value) / se, df)) if se > 0 else float(value == 0)
    return Estimate(value, min(max(bounds[0], value - half), value), max(min(
        bounds[1], value + half), value), method=method, se=float(se), df=float(df),
        p_value=p, **fields)


def _difference(xa, xb, kind: str, scenes: str, level: float, bounds) -> Estimate:
    """a - b: paired t, Welch's t, or (one seed) a normal interval on paired episodes."""
    seeds, pct = (len(xa), len(xb)), f"{100 * level:g}%"
    value = float(_per_seed(xa).mean() - _per_seed(xb).mean())
    common = dict(n=sum(seeds), seeds=seeds, episodes=int(xa.size + xb.size))
    if min(seeds) < 2:
        d = xa.mean(axis=0) - xb.mean(axis=0)  # (T, E): the same episodes in both rows
        var = d.var(axis=1, ddof=1).sum() / d.size / len(d) if d.shape[1] > 1 else 0.0
        half = float(ndtri(0.5 + level / 2)) * math.sqrt(var)
        return Estimate(value, max(bounds[0], value - half), min(bounds[1], value + half),
                        method=f"one seed: episode noise only, {pct} (no verdict)", **common)
    if scenes == "per_seed" and seeds[0] == seeds[1]:
        return _t(value, math.sqrt(_variance([xa, xb], kind) / seeds[0]), seeds[0] - 1,
                  level, f"paired t on {seeds[0]} seeds {pct}", bounds, **common)
    u = [_variance([x], kind) / len(x) for x in (xa, xb)]
    den = sum(ui * ui / (s - 1) for ui, s in zip(u, seeds, strict=True))
    df = sum(u) ** 2 / den if den > 0 else sum(seeds) - 2  # Welch-Satterthwaite
    return _t(value, math.sqrt(sum(u)), df, level,
              f"welch t on {seeds[0]}+{seeds[1]} seeds {pct}", bounds, **common)


def success_rate(outcomes, *, level: float = 0.95) -> Estimate:
    """A row's success rate: the t interval on per-seed values (one seed: its episodes'
    noise), never narrower than the Wilson interval of all its episodes."""
    x, pct = as_outcomes(outcomes), f"{100 * level:g}%"
    check_level(level)
    S, T, E = x.shape
    low, high = wilson_interval(int(round(x.sum())), x.size, level)
    if S >= 2:
        est = _t(float(x.mean()), math.sqrt(_variance([x], "success") / S), S - 1, level,
                 f"t on {S} seeds {pct}", (0.0, 1.0), n=S, seeds=(S,), episodes=int(x.size))
        return replace(est, low=min(est.low, low), high=max(est.high, high), p_value=None)
    if T > 1:
        est = _difference(x, 0 * x, "success", "shared", level, (0.0, 1.0))
        low, high = min(low, est.low), max(high, est.high)
    method = "wilson" if T == 1 else "stratified normal"
    return Estimate(float(x.mean()), low, high, 1, f"one seed: {method} {pct} (episodes "
                    "only)", seeds=(1,), episodes=int(x.size))


def paired_difference(a, b, *, scenes: str = "shared", level: float = 0.95) -> Estimate:
    """Success of row `a` minus row `b`, (seeds, tasks, episodes) on the same episodes: the
    paired t with scenes "per_seed" (seed k of both rows on scene set k), else Welch's t."""
    xa, xb = as_outcomes(a, "a"), as_outcomes(b, "b")
    if xa.shape[1:] != xb.shape[1:]:
        raise ValueError(f"paired rows need the same (tasks, episodes): a has {xa.shape[1:]}, "
                         f"b has {xb.shape[1:]} (shapes {xa.shape} and {xb.shape})")
    if scenes not in ("shared", "per_seed"):
        raise ValueError(f"scenes must be 'shared' or 'per_seed', got {scenes!r}")
    check_level(level)
    return _difference(xa, xb, "success", scenes, level, (-1.0, 1.0))


def paired_score_difference(a, b, *, level: float = 0.95) -> Estimate:
    """Mean score of `a` minus `b`, (seeds, trajectories) each: Welch's t on per-seed means."""
    xa, xb = as_scores(a, "a"), as_scores(b, "b")
    if xa.shape[1] != xb.shape[1]:
        raise ValueError(f"paired rows need the same trajectories: a has {xa.shape[1]}, "
                         f"b has {xb.shape[1]}")
    check_level(level)
    return _difference(xa[:, None], xb[:, None], "score", "shared", level, (-math.inf, math.inf))


def best_of(a, others: Sequence, difference, sign: int = +1) -> Estimate:
    """Row `a` minus the best of `others` (`sign` -1: the lowest); components: each pair."""
    if not len(others):
        raise ValueError("best of k needs at least one other row")
    pairwise, means = [difference(a, o) for o in others], [float(np.mean(o)) for o in others]
    best, side = int(np.argmax(sign * np.asarray(means))), "best" if sign > 0 else "lowest"
    closest, value = pairwise[best], float(np.mean(a)) - means[best]
    seeds = (pairwise[0].seeds[0], *(c.seeds[1] for c in pairwise))
    return Estimate(value, min(closest.low, value), max(closest.high, value), n=sum(seeds),
                    method=f"margin over the {side} other row: intersection test over "
                    f"{len(pairwise)} rows ({closest.method} to the {side} other row)",
                    seeds=seeds, episodes=int(np.size(a) + sum(np.size(o) for o in others)),
                    components=tuple(pairwise))


def score_mean(scores, *, level: float = 0.95) -> Estimate:
    """The mean of (seeds, trajectories) scores: the t interval on per-seed means."""
    x, pct = as_scores(scores)[:, None], f"{100 * level:g}%"
    check_level(level)
    if len(x) >= 2:
        return _t(float(x.mean()), math.sqrt(_variance([x], "score") / len(x)), len(x) - 1,
                  level, f"t on {len(x)} seeds {pct}", n=len(x), seeds=(len(x),),
                  episodes=int(x.size))
    est = _difference(x, 0 * x, "score", "shared", level, (-math.inf, math.inf))
    return replace(est, n=1, seeds=(1,), episodes=int(x.size),
                   method=f"one seed: normal over trajectories {pct}")


def rank_correlation(x_rows: Sequence, y_rows: Sequence, kinds=("score", "success"), *,
                     n_boot: int = 2000, rng_seed: int = 0, level: float = 0.95) -> Estimate:
    """Spearman correlation across rows of two quantities (outcomes or scores, by `kinds`):
    a joint bootstrap of every row's seeds, then units in strata; percentile interval."""
    if len(x_rows) != len(y_rows) or len(x_rows) < 3:
        raise ValueError(f"one x and one y per row, at least 3 rows: got {len(x_rows)} and "
                         f"{len(y_rows)}")
    check_level(level, n_boot)
    rows = [[as_outcomes(r) if kind == "success" else as_scores(r)[:, None] for r in q]
            for q, kind in zip((x_rows, y_rows), kinds, strict=True)]
    if any(len({r.shape[1:] for r in q}) > 1 for q in rows):
        raise ValueError("every row must have the same tasks and episodes (trajectories)")
    rng, rho = np.random.default_rng(rng_seed), []
    for q in rows:  # (rows, 1 + n_boot): the point values, then each resample
        idx = rng.integers(0, q[0].shape[2], size=(n_boot, *q[0].shape[1:]))
        w = [rng.multinomial(len(r), np.full(len(r), 1 / len(r)), n_boot) / len(r) for r in q]
        boot = [np.take_along_axis(np.einsum("bs,ste->bte", wr, r), idx, 2).mean(axis=(1, 2))
                for wr, r in zip(w, q, strict=True)]
        ranks = sps.rankdata(np.c_[[r.mean() for r in q], boot], axis=0)
        rho.append(ranks - ranks.mean(axis=0))
    den = np.sqrt((rho[0] ** 2).sum(axis=0) * (rho[1] ** 2).sum(axis=0))
    r = np.divide((rho[0] * rho[1]).sum(axis=0), den, out=np.zeros(den.shape), where=den > 0)
    low, high = np.percentile(r[1:], [50 * (1 - level), 50 * (1 + level)])
    tail = min(np.mean(r[1:] <= 0), np.mean(r[1:] >= 0))
    return Estimate(float(r[0]), min(low, r[0]), max(high, r[0]), len(rows[0]),
                    f"spearman, joint bootstrap {100 * level:g}%",
                    seeds=tuple(min(len(u), len(v)) for u, v in zip(*rows, strict=True)),
                    p_value=float(min(1.0, max(2 * tail, 1 / n_boot))))


# --------------------------------------------------------------------------------- verdict
def _side(low, high, direction: int, threshold) -> int:
    """+1: the interval lies beyond `threshold` on the claimed side; -1: short of it; 0."""
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 (claimed above) or -1 (below), got {direction}")
    low, high, threshold = (-high, -low, -threshold) if direction < 0 else (low, high, threshold)
    return 1 if low > threshold else -1 if high < threshold else 0


def verdict(estimate: Estimate, direction: int = +1, threshold: float = 0.0) -> Verdict:
    """Holds when the interval lies beyond `threshold` on the claimed side, does not hold on
    the other (best of k: every pairwise interval; one at 1 - ALPHA/k), else inconclusive."""
    side, comps = _side(estimate.low, estimate.high, direction, threshold), estimate.components
    if not estimate.decidable or any(not c.decidable for c in comps):
        return Verdict.TOO_FEW_SEEDS
    if comps:
        strict = [_side(*(repeated_interval(c.value, c.se, c.df, ALPHA / len(comps)) if c.se
                          is not None else (c.low, c.high)), direction, threshold) for c in comps]
        side = 1 if all(_side(c.low, c.high, direction, threshold) == 1 for c in comps) else \
            -1 if -1 in strict else 0
    return {1: Verdict.HOLDS, -1: Verdict.DOES_NOT_HOLD, 0: Verdict.INCONCLUSIVE}[side]


def decision_p_value(estimate: Estimate, direction: int = +1) -> tuple[float, Verdict] | None:
    """(p, side) of the test behind `verdict` (None: untestable). Best of k: "holds" max_j p_j
    (intersection-union), "does not hold" k min_j p_j over the rows that beat it."""
    comps = estimate.components or (estimate,)
    if verdict(estimate, direction) == Verdict.TOO_FEW_SEEDS or any(
            c.p_value is None for c in comps):
        return None
    against = [c.p_value for c in comps if direction * c.value <= 0]
    if not estimate.components:
        return float(estimate.p_value), Verdict.DOES_NOT_HOLD if against else Verdict.HOLDS
    p_hold = 1.0 if against else max(c.p_value for c in comps)
    p_against = min(1.0, len(comps) * min(against)) if against else 1.0
    return (p_hold, Verdict.HOLDS) if p_hold <= p_against else (p_against, Verdict.DOES_NOT_HOLD)


# ---------------------------------------------------------------------------- multiplicity
def weighted_holm(weights) -> np.ndarray:
    """Weighted Holm's graph: g_ij = w_j / sum_{k != i} w_k (Bretz et al. 2009)."""
    g = np.where(np.eye(len(weights), dtype=bool), 0.0, np.asarray(weights, np.float64))
    s = g.sum(axis=1, keepdims=True)
    return np.divide(g, s, out=np.zeros_like(g), where=s > 0)


def graph_test(p_values, weights, transitions=None, alpha: float = ALPHA):
    """Bretz et al. (2009, Algorithm 1): reject a claim with p <= alpha w_i, pass its weight
    on along the graph, repeat (None: untested). Returns (rejected, the weights at the end)."""
    p = np.array([np.nan if v is None else v for v in p_values], np.float64)
    w = np.array(weights, np.float64)
    g = weighted_holm(w) if transitions is None else np.array(transitions, np.float64)
    if w.shape != p.shape or g.shape != (len(w),) * 2 or (w < 0).any() or w.sum() > 1 + 1e-9:
        raise ValueError(f"one weight >= 0 per p-value, summing to at most 1, and a square "
                         f"transition matrix: got {len(p)} p-values and weights {w.tolist()}")
    rejected, active = np.zeros(len(p), bool), np.ones(len(p), bool)
    leave = list(np.flatnonzero(np.isnan(p)))
    while leave or (hit := np.flatnonzero(active & (p <= alpha * w * (1 + 1e-12)))).size:
        j = leave.pop() if leave else hit[np.argmin(p[hit])]
        rejected[j], active[j] = not np.isnan(p[j]), False
        w[active] += w[j] * g[j, active]
        den = (1 - g[:, j] * g[j, :])[:, None]
        g = np.divide(g + np.outer(g[:, j], g[j]), den, out=np.zeros_like(g), where=den > 1e-12)
        g[~active], g[:, ~active], w[j] = 0.0, 0.0, 0.0
        np.fill_diagonal(g, 0.0)
    return rejected, w


def holm(p_values: Sequence[float | None], alpha: float = ALPHA) -> list[bool]:
    """Holm's (1979) step-down procedure, the graph with equal weights; None: not tested."""
    return graph_test(p_values, np.full(len(p_values), 1 / max(len(p_values), 1)),
                      alpha=alpha)[0].tolist()


def adjusted_verdicts(estimates: Sequence[Estimate | None], directions: Sequence[int],
                      alpha: float = ALPHA, weights=None, tested=None) -> list[Verdict]:
    """Verdicts after the graph (Holm; with `weights`, weighted Holm): a rejected claim keeps
    its side, any other is inconclusive, or too few seeds / not run (None) as it was; one
    not `tested` (a descriptive claim; default: all are) is in the graph without a test."""
    tests = [decision_p_value(e, d) if e is not None and test else None for e, d, test in
             zip(estimates, directions, tested or [True] * len(estimates), strict=True)]
    weights = np.full(len(tests), 1 / max(len(tests), 1)) if weights is None else weights
    rejected = graph_test([t and t[0] for t in tests], weights, alpha=alpha)[0]
    return [Verdict.NOT_RUN if e is None else t[1] if r
            else Verdict.TOO_FEW_SEEDS if verdict(e, d) == Verdict.TOO_FEW_SEEDS
            else Verdict.INCONCLUSIVE
            for e, d, t, r in zip(estimates, directions, tests, rejected, strict=True)]


# ----------------------------------------------------------------------------------- size
def repeated_interval(value, se, df, alpha, design: SequentialDesign | None = None,
                      look: int = 0):
    """value -+ t se at a look's nominal level for `alpha` (all looks cover at once with
    probability 1 - alpha); without a design, the interval at 1 - alpha. Vectorised."""
    nominal = alpha if design is None else design.nominal_level(alpha, look)
    half = sps.t.isf(np.asarray(nominal) / 2, df) * np.asarray(se)
    return np.asarray(value) - half, np.asarray(value) + half


def size_decision(estimate: Estimate, direction: int, effect: float | None, alpha: float,
                  design: SequentialDesign | None = None, look: int = 0) -> Size | None:
    """Our effect against the paper's `effect` by repeated intervals at `alpha` (a claim's
    Bonferroni share): larger when beyond it on the claimed side (best of k: every pairwise
    one), smaller when short of it (one at alpha / k), else undecided; None: unreadable."""
    comps = () if effect is None else estimate.components or (estimate,)
    if not comps or verdict(estimate, direction) == Verdict.TOO_FEW_SEEDS or any(
            c.se is None for c in comps):
        return None
    sides = [[_side(*repeated_interval(c.value, c.se, c.df, a, design, look), direction, effect)
              for c in comps] for a in (alpha, alpha / len(comps))]
    return (Size.LARGER if min(sides[0]) == 1 else Size.SMALLER if -1 in sides[1]
            else Size.UNDECIDED)


# ---------------------------------------------------------------------------- planning
def _plan(var, seeds, alpha, paired):
    n = np.asarray(seeds, np.float64)
    if np.any(n < 2) or np.any(np.asarray(var) < 0):
        raise ValueError(f"a design needs 2 seeds a row and a variance >= 0: {seeds}, {var}")
    df = n - 1 if paired else 2 * n - 2
    return df, np.sqrt(np.asarray(var) / n), sps.t.isf(np.asarray(alpha) / 2, df)


def minimum_detectable(var, seeds, *, alpha=ALPHA, power: float = POWER, paired: bool = True):
    """The least true difference a test at `alpha` detects with `power`, (t_{1-alpha/2} +
    t_{power}) sqrt(var / n): var of d_k (paired, df n - 1), else var_a + var_b (df 2n - 2)."""
    df, se, crit = _plan(var, seeds, alpha, paired)
    out = (crit + sps.t.ppf(power, df)) * se
    return float(out) if np.ndim(out) == 0 else out


def power_at(var, seeds, effect, *, alpha=ALPHA, paired: bool = True):
    """The chance that that test detects a true `effect` (the inverse of the above)."""
    df, se, crit = _plan(var, seeds, alpha, paired)
    z = np.divide(np.abs(effect), se, out=np.full(np.shape(se), np.inf), where=se > 0)
    return float(sps.t.sf(crit - z, df)) if np.ndim(z) == 0 else sps.t.sf(crit - z, df)


def seeds_needed(var, effect, *, alpha=ALPHA, power: float = POWER, paired: bool = True,
                 max_seeds: int = 1000) -> int | None:
    """The fewest seeds a row at which `minimum_detectable` reaches |effect| (None: never)."""
    n = np.arange(2, max_seeds + 1)
    fits = np.flatnonzero(minimum_detectable(var, n, alpha=alpha, power=power, paired=paired)
                          <= abs(effect)) if 0 < abs(effect) < math.inf else []
    return int(n[fits[0]]) if len(fits) else None


def episodes_per_seed(seed_var: float, episode_var: float, train_cost: float,
                      episode_cost: float) -> float:
    """Episodes per task minimising variance times cost, (seed_var + episode_var / E) (train
    + E episode): E = sqrt(episode_var train_cost / (seed_var episode_cost))."""
    for name, v in (("seed_var", seed_var), ("episode_var", episode_var),
                    ("train_cost", train_cost), ("episode_cost", episode_cost)):
        if not 0 < v < math.inf:
            raise ValueError(f"episodes_per_seed: {name} must be a positive number, got {v}")
    return math.sqrt(episode_var * train_cost / (seed_var * episode_cost))


# ------------------------------------------------------------------------- seeds in stages
_LEVELS = np.unique(np.r_[np.geomspace(1e-20, 0.5, 201), ALPHA])  # tabulated levels


@dataclass(frozen=True)
class SequentialDesign:
    """Looks at `stages` seeds a row (cumulative), two-sided boundaries by Lan-DeMets
    spending ("obf" or "pocock") at information fractions n_k / n_K: at (5, 10, 15) and 5%,
    a look decides at p <= 0.0007, 0.016, 0.044 (`nominal_levels`)."""

    stages: tuple[int, ...]
    alpha: float = ALPHA
    spending: str = "obf"

    def __post_init__(self):
        stages = tuple(int(s) for s in self.stages)
        if not stages or stages[0] < 2 or any(np.diff(stages) <= 0):
            raise ValueError(f"stages must be increasing seed counts, each at least 2 (a "
                             f"variance needs two seeds), got {self.stages}")
        if self.spending not in ("obf", "pocock"):
            raise ValueError(f"spending must be 'obf' or 'pocock', got {self.spending!r}")
        object.__setattr__(self, "stages", stages)
        check_level(1 - self.alpha)

    @property
    def fractions(self) -> np.ndarray:
        return np.asarray(self.stages) / self.stages[-1]

    def spent_alpha(self, t, alpha: float | None = None):
        """Error spent by information fraction t (Lan and DeMets 1983): "obf"
        2 - 2 Phi(z_{1-alpha/2} / sqrt(t)), "pocock" alpha ln(1 + (e - 1) t)."""
        t, alpha = np.asarray(t, np.float64), alpha or self.alpha
        return (2 * ndtr(ndtri(alpha / 2) / np.sqrt(t)) if self.spending == "obf"
                else alpha * np.log1p((math.e - 1) * t))

    def boundaries(self, alpha: float | None = None) -> np.ndarray:
        """z boundaries c_k, P(|Z_j| < c_j, j < k; |Z_k| >= c_k) = alpha(t_k) - alpha(t_{k-1})
        under no difference: the sub-density of the score Z_k sqrt(t_k) is carried from look to
        look on a Simpson grid (Armitage et al. 1969; Jennison and Turnbull, ch. 19)."""
        t, spent = self.fractions, self.spent_alpha(self.fractions, alpha)
        c = np.full(len(t), np.inf)
        c[0] = -ndtri(spent[0] / 2)
        simpson = np.r_[1, np.tile([4, 2], 99), 4, 1] / 3
        s = np.linspace(-1, 1, 201) * c[0] * math.sqrt(t[0])
        mass = np.exp(-s * s / (2 * t[0])) / math.sqrt(2 * math.pi * t[0])
        for k in range(1, len(t)):
            sd, root = math.sqrt(t[k] - t[k - 1]), math.sqrt(t[k])
            mass, increment = mass * simpson * (s[1] - s[0]), float(spent[k] - spent[k - 1])

            def excess(ck, mass=mass, s=s, sd=sd, root=root, increment=increment):
                exits = ndtr((s - ck * root) / sd) + ndtr((-ck * root - s) / sd)
                return (mass * exits).sum() - increment

            if increment <= 0 or excess(40.0) >= 0:
                break  # nothing left to spend: no decision from here on
            c[k] = brentq(excess, 0.0, 40.0, xtol=1e-10)
            u = np.linspace(-1, 1, 201) * c[k] * root
            mass = np.exp(-((u[:, None] - s) ** 2) / (2 * sd * sd)) @ mass / math.sqrt(
                2 * math.pi) / sd
            s = u
        return c

    def nominal_levels(self, alpha: float | None = None) -> np.ndarray:
        """Each look's boundary as a p-value threshold for its t-test (ibid., Sec. 11.4)."""
        return 2 * ndtr(-self.boundaries(alpha))

    @lru_cache(maxsize=16)  # noqa: B019 (a few designs, each tabulated once)
    def _table(self) -> np.ndarray:
        """(levels, looks) log nominal thresholds at each of `_LEVELS` (nan: nothing spent)."""
        with np.errstate(divide="ignore"):
            table = np.log(np.stack([self.nominal_levels(a) for a in _LEVELS]))
        return np.where(np.isfinite(table), table, np.nan)

    def nominal_level(self, alpha, look: int):
        """`nominal_levels(alpha)[look]` from the tabulated levels, vectorised over alpha."""
        col = self._table()[:, look]
        return np.exp(np.interp(np.log(np.maximum(alpha, 1e-300)), np.log(_LEVELS[col == col]),
                                col[col == col]))

    def repeated_p_value(self, p, look: int):
        """The smallest level whose boundary at `look` the nominal p-value crosses (1 beyond
        0.5): under no difference P(min over looks <= u) <= u, whichever looks happen."""
        col = self._table()[:, look]
        col, levels = col[col == col], np.log(_LEVELS[col == col])  # nan: nothing spent
        logp = np.log(np.clip(np.asarray(p, np.float64), 1e-300, 1.0))
        return np.where(logp > col[-1], 1.0, np.exp(np.interp(logp, col, levels)))

    def p_values(self, looks: Sequence[Estimate], direction: int
                 ) -> list[tuple[float, Verdict] | None]:
        """Per look (looks[k]: the first `stages[k]` seeds a row), the running least
        `decision_p_value` on repeated p-values, with its side."""
        out, best = [], None
        for k, est in enumerate(looks):
            first, *rest = [replace(e, p_value=None if e.p_value is None else float(
                self.repeated_p_value(e.p_value, k))) for e in (est, *est.components)]
            test = decision_p_value(replace(first, components=tuple(rest)), direction)
            best = test if test is not None and (best is None or test[0] < best[0]) else best
            out.append(best)
        return out

    def conditional_power(self, p, look: int, alpha):
        """The chance of crossing the last boundary at level `alpha` if the effect seen at
        `look` (nominal p-value `p`) is the truth: Phi((z / sqrt(t) - c_K) / sqrt(1 - t)),
        the "current trend" (Jennison and Turnbull, Sec. 10.1); 0 at the last look."""
        t = self.fractions[look]
        z = -ndtri(np.clip(np.asarray(p, np.float64), 1e-300, 1.0) / 2)
        c = -ndtri(self.nominal_level(alpha, len(self.stages) - 1) / 2)
        return ndtr((z / math.sqrt(t) - c) / math.sqrt(1 - t)) if t < 1 else 0 * (z + c)


def sequential_graph(p_by_look: Sequence[Sequence[float | None]], weights, transitions=None,
                     alpha: float = ALPHA) -> tuple[list[int | None], np.ndarray]:
    """The graph at every look (Maurer and Bretz 2013) on running repeated p-values
    p_by_look[i][k] (a claim with fewer looks carries its last). Returns per claim the first
    look that rejects it (None: never), and the levels after each look (looks, claims)."""
    looks = max((len(p) for p in p_by_look), default=0)
    decided: list[int | None] = [None] * len(p_by_look)
    levels = np.zeros((looks, len(p_by_look)))
    for k in range(looks):
        rejected, w = graph_test([p[min(k, len(p) - 1)] if len(p) else None for p in p_by_look],
                                 weights, transitions, alpha)
        levels[k] = alpha * w
        decided = [k if r and d is None else d for d, r in zip(decided, rejected, strict=True)]
    return decided, levels
