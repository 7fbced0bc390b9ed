"""Statistics behind every table and claim: success rates with intervals, seed-aware
differences, the verdict rule, Holm's correction, size and power.

    from icil_paper.stats import paired_difference, success_rate, verdict
    row = success_rate(outcomes)               # outcomes: bools (seeds, tasks, episodes)
    row.value, row.low, row.high               # mean success and its 95% interval
    diff = paired_difference(lipvq, bc)        # same tasks and episodes in both rows
    verdict(diff, direction=+1)                # "holds", "does not hold", "inconclusive"
                                               # or "too few seeds"

**The unit of replication is the training seed.** A row is trained with S seeds and each
seed is evaluated on T tasks x E episodes (outcomes shaped (seeds, tasks, episodes)). The
row's value is the mean over seeds of the mean over tasks of each task's success rate, so
every task weighs the same. What varies from one replication of an experiment to the next is
mostly the training seed (on our records the spread between seeds is 70-96% of a
comparison's variance), so intervals are built from *per-seed values* v_s (the seed's mean
over tasks and episodes): each v_s already carries its own episode noise, and their spread
carries both the seed's and the episodes' luck. This is the standard analysis of seeded
learning experiments (Colas, Sigaud and Oudeyer 2018, "How many random seeds? Statistical
power analysis in deep reinforcement learning experiments"; Agarwal et al. 2021, "Deep RL
at the edge of the statistical precipice", who also treat runs as the unit).

- A row with S >= 2 seeds: the t interval mean(v) +- t_{S-1} sd(v) / sqrt(S) (Student 1908),
  never narrower than the Wilson interval of all its episodes pooled (a row that failed every
  episode is not known to be exactly 0).
- A row with one seed: its seed variance cannot be estimated. The interval shown describes
  the episodes' luck only (a stratified bootstrap over episodes within tasks, or Wilson for a
  single task); its method says so, and no comparison that reads it is decided.
- A difference of two rows (`paired_difference`): both rows need >= 2 seeds. Two designs:
  *shared scenes* (episode i of task t is the same scene for every seed and row: today's
  records), where scene difficulty cancels from the difference of means and the interval is
  Welch's (1947) t interval on the two rows' per-seed values, se^2 = s_a^2/S_a + s_b^2/S_b
  with the Welch-Satterthwaite degrees of freedom; and *scenes per seed index* (seed k of
  every row is evaluated on scene set k), where seed k of row a and seed k of row b share
  their scenes and the interval is the paired t interval on the per-seed differences
  d_k = v_{a,k} - v_{b,k} (df = S - 1). Where a row's seeds (or the paired differences)
  all have the same value, to rounding (a row at 0 or 1 on every seed; three seeds each
  one episode apart), the variance is taken as the episode noise of one seed's value,
  sum_t p~_t (1 - p~_t) / (E T^2) with the Agresti-Coull p~_t = (k_t + 2) / (n_t + 4), so
  that it keeps an honest width instead of a zero one.
- Assumptions: seeds are independent draws of the training randomness; per-seed values are
  close enough to normal for a t interval (they are means of T x E outcomes); under shared
  scenes the inference is conditional on the evaluation scenes (it says what another set
  of training seeds would do on these scenes), under scenes per seed it extends to the
  scene distribution. The calibration test (`tests/test_stats.py`) simulates rows with no
  true difference at the spreads we measure and checks that at most about 5% are decided.

**The verdict rule** (quoted in the claims chapter). Each claim of the paper is a quantity
with a claimed direction: "LipVQ beats LFQ" is the difference LipVQ - LFQ, claimed above 0.
From our 95% interval of that quantity:

- **holds**: the whole interval lies beyond 0 in the claimed direction;
- **does not hold**: the whole interval lies on the other side (the opposite was measured);
- **inconclusive**: the interval contains or touches 0;
- **too few seeds**: a row it reads has a single training seed, so the spread between seeds,
  the largest part of the variance, is unknown; nothing is decided.

"Best of k" claims ("LipVQ-VAE is the best tokenizer") are an intersection-union test
(Berger 1982): the claim holds when LipVQ beats *each* other row (every pairwise interval on
the claimed side, each at 95%, which needs no correction), does not hold when *some* row
beats it (a pairwise interval at the Bonferroni level 1 - 0.05/(k-1) on the other side),
and is inconclusive otherwise. The margin to the largest other row is shown, but it is not
what is tested: the maximum of noisy rows is biased upward, which would make "does not
hold" too easy to reach.

**Multiplicity.** A ledger tests many claims at once. `holm` applies Holm's (1979)
step-down procedure to the claims' p-values at a 5% familywise level; `adjusted_verdicts`
keeps a decided verdict only where Holm rejects. Claims that cannot be tested (too few
seeds, not run) are not in the family.

**Size and power.** `magnitude` reads an interval against the paper's own effect: "paper's
size excluded" (the interval lies entirely short of it), "consistent with the paper's size"
(it holds the paper's value) or "beyond the paper's size", and whether it lies inside an
equivalence margin around 0 (Schuirmann's 1987 two one-sided tests at 5% amount to a 90%
interval inside the margin; we use the 95% interval, which is stricter). `minimum_detectable`
is the smallest difference a design detects with 80% power at the 5% level,
(t_{1-a/2, df} + t_{0.8, df}) se (the normal-approximation power formula with t quantiles,
as in Colas et al. 2018), and `seeds_needed` the seeds per row that bring it down to an
effect of a given size, both from measured per-seed variances.

**Seeds in stages** (`SequentialDesign`; a preset's `tables.seed_stages`). Giving rows more
seeds after looking at their differences, and deciding at every look at 5%, decides a
claim with no true difference far more often than 5% (optional stopping: 10.5% over looks
at 5, 10 and 15 seeds in `tests/test_sequential.py`). A group-sequential design fixes the
looks in advance (seeds a row n_1 < ... < n_K, information fraction t_k = n_k / n_K, a
difference's variance falling as 1/n) and spends each claim's 5% over them with the
Lan-DeMets (1983, "Discrete sequential boundaries for clinical trials", Biometrika 70)
error-spending function of O'Brien-Fleming type, alpha(t) = 2 - 2 Phi(z_{1-alpha/2} /
sqrt(t)): two-sided boundaries c_k with P(|Z_j| < c_j for j < k, |Z_k| >= c_k) =
alpha(t_k) - alpha(t_{k-1}) under no difference, computed by numerical integration of the
looks' joint normal law (Armitage, McPherson and Rowe 1969; Jennison and Turnbull 2000,
"Group Sequential Methods with Applications to Clinical Trials", ch. 7 and 19). At looks
of 5, 10 and 15 seeds this gives c = 3.39, 2.41, 2.02, i.e. a look decides a claim when its
t-test p-value is at most 0.0007, 0.016 and 0.044. O'Brien-Fleming type rather than Pocock
(boundaries about 2.29 at every look) because a look at 5 seeds has a t-test on 4-8
degrees of freedom, the least reliable of the three, and because a claim that runs to the
last look keeps nearly the level (0.044 against 0.05), hence the power, of a single look;
a fixed split of alpha over the looks (Bonferroni) would test the last look at 0.017.

Each look's test is the fixed design's (`paired_difference`, `paired_margin` on the first
n_k seeds of every row: the paired or Welch t, with the episode-noise floor), and its
p-value is compared with the boundary's nominal level (the significance-level approach to
group-sequential t-tests, Jennison and Turnbull 2000, Sec. 11.4). What a claim carries from
look to look is its *repeated p-value* (ibid., Sec. 9.1): at look k, the smallest level
alpha' whose boundary c_k(alpha') the look's statistic crosses (`repeated_p_value`,
tabulated over levels); the claim's p-value is the smallest over its looks so far
(`sequential_p_value`). For every u, P(some look's repeated p-value <= u) <= u under no
difference, whichever looks happen, so rows may stop or go on for any reason. (The
stage-wise ordering p-value, the other common choice, presumes that a trial ends at its
first crossing; here a decided claim's rows may go on for another claim that shares them,
and its later looks must not undo it.) A best-of-k
claim combines its pairwise repeated p-values as `decision_p_value` does (the intersection-
union maximum, or Bonferroni for "does not hold"). Holm's correction is applied to these
p-values over the ledger at every look (`sequential_holm`): a claim is decided at the first
look at which Holm rejects it and stays decided (the p-values only fall), which is the
sequentially rejective group-sequential procedure of Maurer and Bretz (2013, "Multiple
testing in group sequential trials using graphical approaches", Stat. Biopharm. Res. 5)
for Holm's graph: a rejected claim passes its alpha on to the others at every later look.

The stage rule (`icil_paper.planning.design.stage_plan`): after a look, rows whose claims are
all decided stop; a row goes on to the next stage when a claim that reads it is undecided
and `stage_seeds_needed` (the first stage whose boundary detects the paper's effect with
80% power, at the measured per-seed variances) is within the schedule; the others stop,
and the ledger records what they would need (`seeds_needed` at the last look's level).
With a budget (`tables.stage_budget_hours`), only the claims whose next stage fits in it
go on, the cheapest first (`planning.design.within_budget`). Stopping never adds a
decision, so the rule keeps the level, budget included; its cost is the power of the rows
it stops. `tests/test_sequential.py` simulates the whole procedure at the reference
run's spreads: with no true difference 3-5% of claims are decided (about half each way),
and a ledger of six claims with Holm keeps its familywise errors under 5%, with or without
a budget that lets only two claims go on at a look; a true +0.10
holds in 95% of trials with 10.7 seeds a row on average, where a single look needs 12 for
the same power.

Other estimates: smoothness scores (per-trajectory least energies, (seeds, trajectories),
the same held-out trajectories for every seed) follow the same seed-level rules as success
(`score_mean`, `paired_score_difference`, `paired_score_margin`); the rank correlation of
smoothness and success across rows keeps a joint bootstrap over seeds and episodes
(`score_success_correlation`), with "too few seeds" where a row has one seed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any, Literal

import numpy as np

Z_95 = 1.959963984540054
"""The standard normal quantile of a two-sided 95% interval."""

ALPHA = 0.05
"""The tests' level: 95% intervals, a 5% familywise level for Holm's correction."""

POWER = 0.8
"""The power that `minimum_detectable` and `seeds_needed` plan for."""

class Verdict(str, Enum):
    """A claim's verdict (`verdict`). A str enum: it is stored in JSON as its value and
    compares equal to it; the words a chapter prints for it are in `icil_paper.verdict_words`."""

    HOLDS = "holds"
    DOES_NOT_HOLD = "does not hold"
    INCONCLUSIVE = "inconclusive"
    TOO_FEW_SEEDS = "too few seeds"
    """A row behind the estimate has a single training seed: the spread between seeds is
    unknown, nothing is decided."""
    NOT_RUN = "not run"
    """A record the claim reads is missing (the ledger's, never `verdict`'s)."""

    __str__ = str.__str__
    __format__ = str.__format__


Scenes = Literal["shared", "per_seed"]
TOO_FEW_SEEDS = Verdict.TOO_FEW_SEEDS


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
    """The independent units behind it: training seeds (both rows together for a
    difference), or rows for a correlation across rows."""
    method: str
    """How the interval was computed, e.g. "t on 3 seeds 95%" or "welch t 95%"."""
    seeds: tuple[int, ...] = ()
    """Training seeds of each row it reads (one entry per row); empty where not seeded."""
    episodes: int | None = None
    """Episode outcomes (or scored trajectories) behind it, all rows and seeds together."""
    se: float | None = None
    """Standard error of `value` (t-based estimates), else None."""
    df: float | None = None
    """Degrees of freedom of the t interval, else None."""
    p_value: float | None = None
    """Two-sided p-value of "the quantity is 0" (differences and correlations), else None."""
    components: tuple[Estimate, ...] = field(default=())
    """Best-of-k estimates: the pairwise difference to each other row (see the module
    docstring); the verdict is the intersection-union test over them."""

    def __post_init__(self):
        for name in ("value", "low", "high"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"Estimate.{name} must be finite, got {getattr(self, name)}")
        if self.low > self.high:
            raise ValueError(f"Estimate interval is reversed: low {self.low} > high {self.high}")

    @property
    def decidable(self) -> bool:
        """False when a row behind it has a single training seed (its seed variance is
        unknown); True otherwise, including for unseeded estimates."""
        return not self.seeds or min(self.seeds) >= 2

    def interval(self, level: float) -> tuple[float, float]:
        """The t interval at another level (t-based estimates only)."""
        if self.se is None or self.df is None:
            raise ValueError(f"{self.method}: an interval at another level needs a t-based "
                             "estimate (se and df)")
        half = _t_quantile(level, self.df) * self.se
        return self.value - half, self.value + half

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready fields."""
        d: dict[str, Any] = {"value": float(self.value), "low": float(self.low),
                             "high": float(self.high), "n": int(self.n), "method": self.method}
        if self.seeds:
            d["seeds"] = [int(s) for s in self.seeds]
        for name in ("episodes", "se", "df", "p_value"):
            if getattr(self, name) is not None:
                d[name] = float(getattr(self, name)) if name != "episodes" else int(self.episodes)
        if self.components:
            d["components"] = [c.to_dict() for c in self.components]
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Estimate:
        """The inverse of `to_dict`."""
        return cls(value=float(d["value"]), low=float(d["low"]), high=float(d["high"]),
                   n=int(d["n"]), method=str(d["method"]),
                   seeds=tuple(int(s) for s in d.get("seeds", ())),
                   episodes=None if d.get("episodes") is None else int(d["episodes"]),
                   se=d.get("se"), df=d.get("df"), p_value=d.get("p_value"),
                   components=tuple(cls.from_dict(c) for c in d.get("components", ())))

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


def _t_quantile(level: float, df: float) -> float:
    """The t quantile of a two-sided interval at `level` with `df` degrees of freedom."""
    from scipy.stats import t

    return float(t.ppf(0.5 + level / 2, df))


def _check_level(level: float) -> None:
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level}")


def _check_n_boot(n_boot: int) -> None:
    if int(n_boot) != n_boot or n_boot < 100:
        raise ValueError(f"n_boot must be an integer >= 100, got {n_boot}")


def _check_scenes(scenes: str) -> None:
    if scenes not in ("shared", "per_seed"):
        raise ValueError(f"scenes must be 'shared' (every seed on the same scenes) or "
                         f"'per_seed' (seed k of every row on scene set k), got {scenes!r}")


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


def _bootstrap_p(samples: np.ndarray) -> float:
    """Two-sided bootstrap p-value of "the quantity is 0": twice the smaller tail at 0."""
    tail = min(float(np.mean(samples <= 0)), float(np.mean(samples >= 0)))
    return float(min(1.0, max(2 * tail, 1.0 / len(samples))))


def success_rate_samples(outcomes, *, n_boot: int = 2000, rng_seed: int = 0) -> np.ndarray:
    """Bootstrap resamples of a row's success rate, shaped (n_boot,).

    outcomes: bools (seeds, tasks, episodes). Seeds are resampled with replacement (when
    there are several), then episodes within each task, the same episode indices for every
    seed. These are the samples `rank_correlation_interval` combines across rows, and a
    one-seed row's interval (episode noise only) is taken from.
    """
    x = _as_outcomes(outcomes)
    _check_n_boot(n_boot)
    rng = np.random.default_rng(rng_seed)
    S, T, E = x.shape
    idx = _episode_indices(rng, n_boot, T, E)
    return _resampled_rates(x, _seed_weights(rng, n_boot, S), idx)


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


# ------------------------------------------------------------------- seed-level building blocks

def _floored_variance(values: np.ndarray, floor: float) -> float:
    """The sample variance (ddof 1) of per-seed values, or the episode noise `floor` where
    they are all equal (a row at 0 or 1 on every seed is not known exactly). Equal means
    equal to rounding: three seeds one episode apart, -0.05 each, have a variance of 1e-33
    in floating point, which would otherwise give an interval of zero width."""
    if np.allclose(values, values[0], rtol=1e-9, atol=1e-12):
        return floor
    return float(np.var(values, ddof=1))


def _episode_noise(x: np.ndarray) -> float:
    """Variance of one seed's value from its episodes alone: sum_t p~_t (1-p~_t) / (E T^2),
    p~_t the Agresti-Coull rate of task t over all seeds (never 0, even at 0/n or n/n)."""
    S, T, E = x.shape
    k = x.sum(axis=(0, 2))
    p = (k + 2) / (S * E + 4)
    return float((p * (1 - p)).sum() / (E * T * T))


def _per_seed(x: np.ndarray) -> np.ndarray:
    """Each seed's value: its mean over everything else, (seeds, ...) -> (seeds,)."""
    return x.reshape(len(x), -1).mean(axis=1)


def _row_variance(x: np.ndarray, kind: str) -> float:
    """Sample variance (ddof 1) of a row's per-seed values, S >= 2; a success row whose
    seeds all agree gets one seed's episode noise instead of 0."""
    return _floored_variance(_per_seed(x), _episode_noise(x) if kind == "success" else 0.0)


def seed_variance(data, kind: Literal["success", "score"] = "success") -> float | None:
    """The variance between a row's per-seed values (outcomes (seeds, tasks, episodes) or
    scores (seeds, trajectories); a success row whose seeds all agree gets one seed's
    episode noise instead of 0); None for a single seed (it cannot be estimated)."""
    x = _as_outcomes(data) if kind == "success" else _as_scores(data)
    return None if len(x) < 2 else _row_variance(x, kind)


def _welch_df(va: float, na: int, vb: float, nb: int) -> float:
    """Welch-Satterthwaite degrees of freedom of s_a^2/n_a + s_b^2/n_b."""
    ua, ub = va / na, vb / nb
    den = ua * ua / (na - 1) + ub * ub / (nb - 1)
    return float((ua + ub) ** 2 / den) if den > 0 else float(na + nb - 2)


def _t_estimate(value: float, se: float, df: float, level: float, method: str,
                bounds: tuple[float, float], **fields) -> Estimate:
    """value +- t se, clipped to `bounds`, with the two-sided p-value of 0."""
    from scipy.stats import t

    half = _t_quantile(level, df) * se
    low, high = max(bounds[0], value - half), min(bounds[1], value + half)
    if se > 0:
        p = float(2 * t.sf(abs(value) / se, df))
    else:
        p = 1.0 if value == 0 else 0.0
    return Estimate(value, min(low, value), max(high, value), method=method, se=float(se),
                    df=float(df), p_value=p, **fields)


def _seeded_difference(xa: np.ndarray, xb: np.ndarray, *, kind: str, scenes: str,
                       level: float, bounds: tuple[float, float],
                       fallback) -> Estimate:
    """a - b from per-seed values: Welch (shared scenes) or paired t (scenes per seed
    index); `fallback()` gives the episode-only interval where a row has one seed."""
    seeds = (len(xa), len(xb))
    episodes = int(xa.size + xb.size)
    pct = f"{100 * level:g}%"
    va_, vb_ = _per_seed(xa), _per_seed(xb)
    value = float(va_.mean() - vb_.mean())
    if min(seeds) < 2:
        low, high = fallback()
        return Estimate(value, min(low, value), max(high, value), sum(seeds),
                        f"one seed: episode noise only, {pct} (no verdict)", seeds=seeds,
                        episodes=episodes)
    if scenes == "per_seed" and seeds[0] == seeds[1]:
        floor = (_episode_noise(xa) + _episode_noise(xb)) if kind == "success" else 0.0
        var = _floored_variance(va_ - vb_, floor)
        return _t_estimate(value, math.sqrt(var / seeds[0]), seeds[0] - 1, level,
                           f"paired t on {seeds[0]} seeds {pct}", bounds, n=sum(seeds),
                           seeds=seeds, episodes=episodes)
    var_a, var_b = _row_variance(xa, kind), _row_variance(xb, kind)
    se = math.sqrt(var_a / seeds[0] + var_b / seeds[1])
    df = _welch_df(var_a, seeds[0], var_b, seeds[1])
    return _t_estimate(value, se, df, level, f"welch t on {seeds[0]}+{seeds[1]} seeds {pct}",
                       bounds, n=sum(seeds), seeds=seeds, episodes=episodes)


# ------------------------------------------------------------------------------ success rows

def success_rate(outcomes, *, n_boot: int = 2000, rng_seed: int = 0,
                 level: float = 0.95) -> Estimate:
    """A row's success rate with its interval (see the module docstring for the method).

    outcomes: bools (seeds, tasks, episodes), full (no missing episodes). The value is the
    mean over seeds of the mean over tasks of each task's success rate. Several seeds: the t
    interval on per-seed values, at least as wide as the pooled episodes' Wilson interval.
    One seed: episode noise only (Wilson for one task, else a stratified bootstrap over
    episodes, also at least the pooled Wilson interval). Deterministic given `rng_seed`.
    """
    x = _as_outcomes(outcomes)
    _check_level(level)
    _check_n_boot(n_boot)
    S, T, E = x.shape
    value = float(x.mean())
    pct = f"{100 * level:g}%"
    pooled_low, pooled_high = wilson_interval(int(round(x.sum())), x.size, _z(level))
    if S >= 2:
        se = math.sqrt(_row_variance(x, "success") / S)
        half = _t_quantile(level, S - 1) * se
        return Estimate(value, max(0.0, min(value - half, pooled_low)),
                        min(1.0, max(value + half, pooled_high)), S, f"t on {S} seeds {pct}",
                        seeds=(S,), episodes=int(x.size), se=se, df=float(S - 1))
    if T == 1:
        low, high = wilson_interval(int(x.sum()), E, _z(level))
        return Estimate(value, low, high, 1, f"one seed: wilson {pct} (episodes only)",
                        seeds=(1,), episodes=E)
    samples = success_rate_samples(x, n_boot=n_boot, rng_seed=rng_seed)
    low, high = _percentiles(samples, level)
    return Estimate(value, min(low, value, pooled_low), max(high, value, pooled_high), 1,
                    f"one seed: stratified bootstrap {pct} (episodes only)", seeds=(1,),
                    episodes=int(x.size))


def _check_paired_outcomes(xa: np.ndarray, xb: np.ndarray, name_b: str = "b") -> None:
    if xa.shape[1:] != xb.shape[1:]:
        raise ValueError(f"paired rows need the same (tasks, episodes): a has "
                         f"{xa.shape[1:]}, {name_b} has {xb.shape[1:]} (shapes {xa.shape} "
                         f"and {xb.shape})")


def paired_difference(a, b, *, scenes: Scenes = "shared", n_boot: int = 2000,
                      rng_seed: int = 0, level: float = 0.95) -> Estimate:
    """Success rate of row `a` minus that of row `b`, on the same tasks and episodes.

    a: bools (seeds_a, tasks, episodes), b: bools (seeds_b, tasks, episodes). `scenes`:
    "shared" (episode i of task t the same scene for every seed of both rows) gives Welch's
    t interval on the per-seed values; "per_seed" (seed k of both rows on scene set k) the
    paired t interval on per-seed differences (equal seed counts; otherwise Welch). A row
    with one seed gets an interval from the episodes' luck alone (a bootstrap that resamples
    the same episode indices for both rows) and the verdict "too few seeds".
    """
    xa, xb = _as_outcomes(a, "a"), _as_outcomes(b, "b")
    _check_paired_outcomes(xa, xb)
    _check_level(level)
    _check_n_boot(n_boot)
    _check_scenes(scenes)

    def episodes_only():
        rng = np.random.default_rng(rng_seed)
        idx = _episode_indices(rng, n_boot, *xa.shape[1:])
        diffs = (_resampled_rates(xa, _seed_weights(rng, n_boot, len(xa)), idx)
                 - _resampled_rates(xb, _seed_weights(rng, n_boot, len(xb)), idx))
        return _percentiles(diffs, level)

    return _seeded_difference(xa, xb, kind="success", scenes=scenes, level=level,
                              bounds=(-1.0, 1.0), fallback=episodes_only)


def _best_of(pairwise: list[Estimate], a_value: float, other_values: list[float],
             sign: int, what: str, episodes: int) -> Estimate:
    """The margin of a over the best other row (by point value; `sign` -1: lowest) with its
    pairwise differences as components. The shown interval is the one to that row."""
    best = int(np.argmax(sign * np.asarray(other_values)))
    closest = pairwise[best]
    value = float(a_value - other_values[best])
    seeds = (pairwise[0].seeds[0], *(c.seeds[1] for c in pairwise))  # a, then each other
    return Estimate(value, min(closest.low, value), max(closest.high, value), n=sum(seeds),
                    method=f"{what}: intersection test over {len(pairwise)} rows "
                    f"({closest.method} to the {'best' if sign > 0 else 'lowest'} other row)",
                    seeds=seeds, episodes=episodes, components=tuple(pairwise))


def paired_margin(a, others: Sequence, *, scenes: Scenes = "shared", n_boot: int = 2000,
                  rng_seed: int = 0, level: float = 0.95) -> Estimate:
    """Row `a`'s success rate minus the best of `others`, all on the same episodes.

    For claims like "LipVQ-VAE is the best tokenizer". The value is a's rate minus the
    largest other rate; its components are `paired_difference(a, other)` for each other row,
    and `verdict` applies the intersection-union test to them (module docstring).
    """
    xa = _as_outcomes(a, "a")
    xs = [_as_outcomes(o, f"others[{i}]") for i, o in enumerate(others)]
    if not xs:
        raise ValueError("paired_margin needs at least one other row")
    for i, x in enumerate(xs):
        _check_paired_outcomes(xa, x, f"others[{i}]")
    pairwise = [paired_difference(xa, x, scenes=scenes, n_boot=n_boot, rng_seed=rng_seed + i,
                                  level=level) for i, x in enumerate(xs)]
    return _best_of(pairwise, float(xa.mean()), [float(x.mean()) for x in xs], +1,
                    "margin over the best other row", xa.size + sum(x.size for x in xs))


# ------------------------------------------------------------------------------- score rows

def score_mean(scores, *, n_boot: int = 2000, rng_seed: int = 0,
               level: float = 0.95) -> Estimate:
    """The mean of per-trajectory scores, (trajectories,) or (seeds, trajectories): the t
    interval on per-seed means for several seeds, a bootstrap over trajectories for one."""
    x = _as_scores(scores)
    _check_level(level)
    value = float(x.mean())
    S = len(x)
    pct = f"{100 * level:g}%"
    if S >= 2:
        return _t_estimate(value, math.sqrt(_row_variance(x, "score") / S), S - 1, level,
                           f"t on {S} seeds {pct}",
                           (-math.inf, math.inf), n=S, seeds=(S,), episodes=int(x.size))
    low, high = _percentiles(mean_samples(x, n_boot=n_boot, rng_seed=rng_seed), level)
    return Estimate(value, min(low, value), max(high, value), 1,
                    f"one seed: bootstrap over trajectories {pct}", seeds=(1,),
                    episodes=int(x.size))


def paired_score_difference(a, b, *, n_boot: int = 2000, rng_seed: int = 0,
                            level: float = 0.95) -> Estimate:
    """Mean per-trajectory score of row `a` minus that of row `b`.

    a, b: (trajectories,) or (seeds, trajectories), both scored on the same held-out
    trajectories (seed counts may differ). Welch's t interval on per-seed means; a row with
    one seed gets a paired bootstrap over trajectories and the verdict "too few seeds".
    """
    xa, xb = _as_scores(a, "a"), _as_scores(b, "b")
    if xa.shape[1] != xb.shape[1]:
        raise ValueError(f"paired rows need the same trajectories: a has {xa.shape[1]}, "
                         f"b has {xb.shape[1]}")
    _check_level(level)
    _check_n_boot(n_boot)

    def trajectories_only():
        rng = np.random.default_rng(rng_seed)
        idx = rng.integers(0, xa.shape[1], size=(n_boot, xa.shape[1]))
        diffs = (mean_samples(xa, n_boot=n_boot, rng_seed=rng_seed + 1, idx=idx)
                 - mean_samples(xb, n_boot=n_boot, rng_seed=rng_seed + 2, idx=idx))
        return _percentiles(diffs, level)

    return _seeded_difference(xa[:, None, :], xb[:, None, :], kind="score", scenes="shared",
                              level=level, bounds=(-math.inf, math.inf),
                              fallback=trajectories_only)


def paired_score_margin(a, others: Sequence, *, n_boot: int = 2000, rng_seed: int = 0,
                        level: float = 0.95) -> Estimate:
    """Row `a`'s mean score minus the lowest mean score of `others`, on the same trajectories.

    For claims like "LipVQ-VAE is the smoothest" (lower least energy is smoother): below 0
    means `a` scores lower than every other row. Components: `paired_score_difference(a,
    other)` for each other row; `verdict` applies the intersection-union test.
    """
    xa = _as_scores(a, "a")
    xs = [_as_scores(o, f"others[{i}]") for i, o in enumerate(others)]
    if not xs:
        raise ValueError("paired_score_margin needs at least one other row")
    if any(x.shape[1] != xa.shape[1] for x in xs):
        raise ValueError("paired rows need the same trajectories: got "
                         f"{[xa.shape[1], *(x.shape[1] for x in xs)]}")
    pairwise = [paired_score_difference(xa, x, n_boot=n_boot, rng_seed=rng_seed + i,
                                        level=level) for i, x in enumerate(xs)]
    return _best_of(pairwise, float(xa.mean()), [float(x.mean()) for x in xs], -1,
                    "margin under the lowest other row", xa.size + sum(x.size for x in xs))


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
                              level: float = 0.95, seeds: tuple[int, ...] = ()) -> Estimate:
    """Spearman correlation across rows of two quantities, with a percentile interval.

    x_samples, y_samples: (rows, n_boot) bootstrap resamples of each row's two quantities
    (e.g. `mean_samples` of its smoothness scores and `success_rate_samples` of its
    outcomes); column j is one joint resample of every row. x, y: (rows,) point values
    (default: the mean of each row's samples). The value is the Spearman correlation of the
    point values; the interval the percentiles of the correlations of the resamples. A
    resample in which all rows tie on one quantity orders nothing and counts as 0.
    `seeds`: the rows' training seeds (recorded, for the "too few seeds" rule).
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
    samples = _spearman_columns(xs, ys)
    low, high = _percentiles(samples, level)
    return Estimate(value, min(low, value), max(high, value), len(xs),
                    f"spearman, joint bootstrap {100 * level:g}%", seeds=tuple(seeds),
                    p_value=_bootstrap_p(samples))


def score_success_correlation(scores: Sequence, outcomes: Sequence, *, n_boot: int = 2000,
                              rng_seed: int = 0, paired: bool = True,
                              level: float = 0.95) -> Estimate:
    """Spearman correlation across rows of a per-trajectory score and success, with interval.

    scores: per row, its per-trajectory scores, (trajectories,) or (seeds, trajectories);
    outcomes: per row, its bools (seeds, tasks, episodes). For "smoother tokenizers succeed
    more", pass each row's least energies and outcomes: a negative correlation (lower
    energy, higher success) supports the claim. Each joint resample draws every row's seeds
    with replacement, then its trajectories and episodes; with `paired` (the default) every
    row must share trajectories and (tasks, episodes), and one set of indices serves all
    rows. A row with one seed makes the estimate "too few seeds" (its `seeds` records it).
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
    seeds = tuple(min(len(s), len(o)) for s, o in zip(xs, ys, strict=True))
    return rank_correlation_interval(
        np.stack(x_samples), np.stack(y_samples), x=np.array([s.mean() for s in xs]),
        y=np.array([o.mean() for o in ys]), level=level, seeds=seeds)


# --------------------------------------------------------------------------------- verdict

def _oriented(low: float, high: float, direction: int, threshold: float):
    """(low, high, threshold) turned so that the claimed direction is "above"."""
    if direction == -1:
        return -high, -low, -threshold
    return low, high, threshold


def _check_direction(direction: int) -> None:
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 (claimed above the threshold) or -1 (below), "
                         f"got {direction}")


def _interval_verdict(low: float, high: float, direction: int, threshold: float) -> Verdict:
    low, high, threshold = _oriented(low, high, direction, threshold)
    if low > threshold:
        return Verdict.HOLDS
    if high < threshold:
        return Verdict.DOES_NOT_HOLD
    return Verdict.INCONCLUSIVE


def verdict(estimate: Estimate, direction: int = +1, threshold: float = 0.0) -> Verdict:
    """"holds", "does not hold", "inconclusive" or "too few seeds" for a claim about
    `estimate`.

    direction +1: the paper claims the quantity is above `threshold`; -1: below it. Holds
    when the whole interval lies strictly beyond the threshold in the claimed direction,
    does not hold when it lies strictly on the other side, inconclusive otherwise; "too few
    seeds" when a row behind the estimate has a single training seed. A best-of-k estimate
    (with `components`) is decided by the intersection-union test of the module docstring.
    """
    _check_direction(direction)
    if not estimate.decidable or any(not c.decidable for c in estimate.components):
        return TOO_FEW_SEEDS
    if not estimate.components:
        return _interval_verdict(estimate.low, estimate.high, direction, threshold)
    pairwise = [_interval_verdict(c.low, c.high, direction, threshold)
                for c in estimate.components]
    if all(v == Verdict.HOLDS for v in pairwise):
        return Verdict.HOLDS
    k = len(estimate.components)
    strict = 1 - ALPHA / k if k > 1 else 1 - ALPHA
    for c in estimate.components:
        low, high = c.interval(strict) if c.se is not None else (c.low, c.high)
        if _interval_verdict(low, high, direction, threshold) == Verdict.DOES_NOT_HOLD:
            return Verdict.DOES_NOT_HOLD
    return Verdict.INCONCLUSIVE


def decision_p_value(estimate: Estimate, direction: int = +1) -> tuple[float, Verdict] | None:
    """The p-value of the test behind `verdict` (threshold 0) and the verdict it decides
    when it is small enough: (p, "holds" or "does not hold"). None when the estimate cannot
    be tested (too few seeds, or no p-value). For a best-of-k estimate: "holds" has the
    intersection-union p-value max_j p_j (all pairwise differences on the claimed side),
    "does not hold" the Bonferroni p-value (k-1) min_j p_j over the rows that beat it."""
    _check_direction(direction)
    if verdict(estimate, direction) == TOO_FEW_SEEDS:
        return None
    if not estimate.components:
        if estimate.p_value is None:
            return None
        side = Verdict.HOLDS if direction * estimate.value > 0 else Verdict.DOES_NOT_HOLD
        return float(estimate.p_value), side
    comps = estimate.components
    if any(c.p_value is None for c in comps):
        return None
    claimed = [c for c in comps if direction * c.value > 0]
    against = [c for c in comps if direction * c.value <= 0]
    p_hold = max(c.p_value for c in comps) if len(claimed) == len(comps) else 1.0
    p_against = (min(1.0, len(comps) * min(c.p_value for c in against)) if against else 1.0)
    return (p_hold, Verdict.HOLDS) if p_hold <= p_against else (p_against, Verdict.DOES_NOT_HOLD)


def holm(p_values: Sequence[float | None], alpha: float = ALPHA) -> list[bool]:
    """Holm's (1979) step-down procedure: which hypotheses are rejected at familywise level
    `alpha`. None entries are not tested (not in the family) and never rejected.

    The m tested p-values are sorted; the i-th smallest (i = 1..m) is rejected while it is
    at most alpha / (m - i + 1); the first that is not stops the procedure.
    """
    _check_level(1 - alpha)
    tested = sorted((p, i) for i, p in enumerate(p_values) if p is not None)
    m = len(tested)
    rejected = [False] * len(p_values)
    for rank, (p, i) in enumerate(tested):
        if p > alpha / (m - rank):
            break
        rejected[i] = True
    return rejected


def adjusted_verdicts(estimates: Sequence[Estimate | None], directions: Sequence[int],
                      alpha: float = ALPHA) -> list[Verdict]:
    """Each claim's verdict after Holm's correction over all of them: a claim Holm rejects
    keeps the side its test decided ("holds" or "does not hold"), any other testable claim is
    "inconclusive"; "too few seeds" and "not run" (estimate None) stay as they are."""
    tests = [None if e is None else decision_p_value(e, d)
             for e, d in zip(estimates, directions, strict=True)]
    rejected = holm([None if t is None else t[0] for t in tests], alpha)
    out = []
    for e, d, t, r in zip(estimates, directions, tests, rejected, strict=True):
        if e is None:
            out.append(Verdict.NOT_RUN)
        elif t is None:
            out.append(verdict(e, d))
        else:
            out.append(t[1] if r else Verdict.INCONCLUSIVE)
    return out


# ---------------------------------------------------------------------------- size, power

def magnitude(estimate: Estimate, direction: int, paper_value: float,
              margin: float | None = None) -> str:
    """Our interval read against the paper's effect `paper_value` (same quantity and sign):
    "paper's size excluded" (the interval lies entirely short of the paper's value, in the
    claimed direction), "beyond the paper's size" (entirely past it), "consistent with the
    paper's size" (it holds it); with `margin`, "; within +-margin of 0" is added when the
    whole interval lies inside (-margin, margin). "too few seeds" where nothing is decided."""
    _check_direction(direction)
    if verdict(estimate, direction) == TOO_FEW_SEEDS:
        return TOO_FEW_SEEDS
    low, high, paper = _oriented(estimate.low, estimate.high, direction, paper_value)
    if high < paper:
        out = "paper's size excluded"
    elif low > paper:
        out = "beyond the paper's size"
    else:
        out = "consistent with the paper's size"
    if margin is not None and -margin < estimate.low and estimate.high < margin:
        out += f"; within ±{margin:g} of 0"
    return out


def _design_se(var_a: float, var_b: float, seeds_a: int, seeds_b: int) -> tuple[float, float]:
    """(se, Welch df) of a difference of two rows with these per-seed variances and seeds."""
    if min(seeds_a, seeds_b) < 2:
        raise ValueError(f"a design needs at least 2 seeds a row to detect anything, got "
                         f"{seeds_a} and {seeds_b}")
    if var_a < 0 or var_b < 0:
        raise ValueError(f"variances must be >= 0, got {var_a} and {var_b}")
    return (math.sqrt(var_a / seeds_a + var_b / seeds_b),
            _welch_df(var_a, seeds_a, var_b, seeds_b))


def minimum_detectable(var_a: float, var_b: float, seeds_a: int, seeds_b: int, *,
                       level: float = 1 - ALPHA, power: float = POWER) -> float:
    """The smallest true difference a - b that a two-sided test at `level` detects with
    probability `power`, given per-seed variances var_a, var_b and the seeds per row:
    (t_{(1+level)/2, df} + t_{power, df}) sqrt(var_a/S_a + var_b/S_b), Welch's df."""
    from scipy.stats import t

    se, df = _design_se(var_a, var_b, seeds_a, seeds_b)
    return float((_t_quantile(level, df) + t.ppf(power, df)) * se)


def power_at(var_a: float, var_b: float, seeds_a: int, seeds_b: int, effect: float, *,
             level: float = 1 - ALPHA) -> float:
    """The probability that a two-sided test at `level` on these seeds detects a true
    difference `effect` (given per-seed variances var_a, var_b): 1 - T_df(t_{(1+level)/2, df}
    - |effect| / se), Welch's df; the far tail is left out (the inverse of
    `minimum_detectable`: power_at(..., minimum_detectable(...)) = POWER)."""
    from scipy.stats import t

    se, df = _design_se(var_a, var_b, seeds_a, seeds_b)
    if se == 0:
        return 1.0 if effect else 1 - level
    return float(t.sf(_t_quantile(level, df) - abs(float(effect)) / se, df))


def seeds_needed(var_a: float, var_b: float, effect: float, *, level: float = 1 - ALPHA,
                 power: float = POWER, max_seeds: int = 1000) -> int | None:
    """Seeds per row (both rows alike, at least 2) for which `minimum_detectable` reaches
    |effect|; None when even `max_seeds` does not, or when the effect is 0."""
    effect = abs(float(effect))
    if effect == 0 or not math.isfinite(effect):
        return None
    lo, hi = 2, max_seeds
    if minimum_detectable(var_a, var_b, hi, hi, level=level, power=power) > effect:
        return None
    while lo < hi:  # the detectable difference falls with the number of seeds
        mid = (lo + hi) // 2
        if minimum_detectable(var_a, var_b, mid, mid, level=level, power=power) <= effect:
            hi = mid
        else:
            lo = mid + 1
    return lo


def episodes_per_seed(seed_var: float, episode_var: float, train_cost: float,
                      episode_cost: float) -> float:
    """Episodes per task and seed that make a row's mean narrowest for its compute.

    A row of S seeds with E episodes per task has variance (seed_var + episode_var / E) / S
    and costs S (train_cost + E episode_cost): `seed_var` is the spread of the seeds' true
    success (episode noise removed), `episode_var` the episode noise of one seed's value
    at one episode per task (sum_t p_t (1 - p_t) / T^2), `train_cost` a seed's fixed cost and
    `episode_cost` the cost of one more episode on every task. The product of variance and
    cost is smallest at E = sqrt(episode_var train_cost / (seed_var episode_cost)), the
    optimum of two-stage sampling (Cochran 1977, "Sampling Techniques", Sec. 10.6): where
    seeds differ much more than episodes, spend the compute on seeds."""
    for name, value in (("seed_var", seed_var), ("episode_var", episode_var),
                        ("train_cost", train_cost), ("episode_cost", episode_cost)):
        if not value > 0 or not math.isfinite(value):
            raise ValueError(f"episodes_per_seed: {name} must be a positive number, got {value}")
    return math.sqrt(episode_var * train_cost / (seed_var * episode_cost))


# ------------------------------------------------------------------------- seeds in stages

Spending = Literal["obf", "pocock"]

_GRID = 201
"""Points of the Simpson grid on which `_boundaries` integrates the sub-densities (the
boundaries agree with a 401-point grid's to 1e-9)."""
_LEVELS = np.unique(np.r_[np.geomspace(1e-20, 0.5, 201), ALPHA])
"""Levels at which `SequentialDesign` tabulates its boundaries for the repeated p-values
(log-linear interpolation between them; `ALPHA` itself is one, so a look's decision at
the claim's own level is exact)."""


def spent_alpha(t, alpha: float = ALPHA, spending: Spending = "obf"):
    """The two-sided type I error spent by information fraction t in (0, 1] (Lan and DeMets
    1983): "obf" 2 - 2 Phi(z_{1-alpha/2} / sqrt(t)) (O'Brien-Fleming type), "pocock"
    alpha ln(1 + (e - 1) t) (Pocock type). Both spend `alpha` at t = 1."""
    from scipy.special import ndtr, ndtri

    t = np.asarray(t, dtype=np.float64)
    if spending == "obf":
        return 2 * ndtr(ndtri(alpha / 2) / np.sqrt(t))  # tail form: exact at tiny alpha
    if spending == "pocock":
        return alpha * np.log1p((math.e - 1) * t)
    raise ValueError(f"spending must be 'obf' or 'pocock', got {spending!r}")


def _simpson(n: int, width: float) -> np.ndarray:
    w = np.ones(n)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    return w * width / (3 * (n - 1))


def _boundaries(fractions: tuple[float, ...], alpha: float, spending: Spending) -> np.ndarray:
    """Two-sided boundaries c_k on the z scale at information fractions t_k: under no
    difference, P(|Z_j| < c_j for j < k, |Z_k| >= c_k) = alpha(t_k) - alpha(t_{k-1}).

    The score S_k = Z_k sqrt(t_k) is a Brownian motion at times t_k; its sub-density on the
    continuation region is carried from look to look by numerical integration (Armitage,
    McPherson and Rowe 1969; Jennison and Turnbull 2000, ch. 19), Simpson's rule on
    `_GRID` points."""
    from scipy.optimize import brentq
    from scipy.special import ndtr, ndtri

    spent = spent_alpha(np.asarray(fractions), alpha, spending)
    out = np.empty(len(fractions))
    out[0] = -ndtri(spent[0] / 2)
    s = f = w = None
    for k in range(len(fractions)):
        if k == 0:
            b = out[0] * math.sqrt(fractions[0])
            s = np.linspace(-b, b, _GRID)
            w = _simpson(_GRID, 2 * b)
            f = np.exp(-s * s / (2 * fractions[0])) / math.sqrt(2 * math.pi * fractions[0])
            continue
        sd = math.sqrt(fractions[k] - fractions[k - 1])
        root = math.sqrt(fractions[k])
        increment = float(spent[k] - spent[k - 1])

        def exit_(c, s=s, f=f, w=w, sd=sd, root=root):
            tails = ndtr((s - c * root) / sd) + ndtr((-c * root - s) / sd)
            return float((w * f * tails).sum())

        if increment <= 0 or exit_(40.0) >= increment:
            out[k:] = np.inf  # nothing left to spend: no decision at this look
            break
        out[k] = brentq(lambda c, inc=increment: exit_(c) - inc, 0.0, 40.0, xtol=1e-10)
        b = out[k] * root
        u = np.linspace(-b, b, _GRID)
        kernel = np.exp(-((u[:, None] - s[None, :]) ** 2) / (2 * sd * sd))
        f, s, w = kernel @ (w * f) / (math.sqrt(2 * math.pi) * sd), u, _simpson(_GRID, 2 * b)
    return out


@dataclass(frozen=True)
class SequentialDesign:
    """A group-sequential design over training seeds: looks at `stages` seeds a row (the
    last is the most any row gets), two-sided boundaries from Lan-DeMets alpha spending
    (see the module docstring, "Seeds in stages").

        design = SequentialDesign((5, 10, 15))
        design.boundaries()                 # z boundaries per look: about 3.71, 2.51, 1.99
        design.nominal_levels()             # the same as two-sided p-value thresholds
        design.repeated_p_value(p, look)    # a look's t-test p-value -> the design's p-value
    """

    stages: tuple[int, ...]
    """Seeds a row at each look, increasing; each a look's *cumulative* seeds."""
    alpha: float = ALPHA
    """Two-sided type I error of each claim's test over all its looks."""
    spending: Spending = "obf"
    """The spending function: "obf" (O'Brien-Fleming type) or "pocock" (Pocock type)."""

    def __post_init__(self):
        stages = tuple(int(s) for s in self.stages)
        if not stages or stages[0] < 2 or any(b <= a for a, b in zip(stages[:-1], stages[1:], strict=True)):
            raise ValueError(f"stages must be increasing seed counts, each at least 2 (a "
                             f"variance needs two seeds), got {self.stages}")
        object.__setattr__(self, "stages", stages)
        _check_level(1 - self.alpha)
        spent_alpha(1.0, self.alpha, self.spending)  # checks `spending`

    @property
    def fractions(self) -> tuple[float, ...]:
        """Information fractions t_k = n_k / n_K (a difference's variance falls as 1/n)."""
        return tuple(s / self.stages[-1] for s in self.stages)

    def boundaries(self, alpha: float | None = None) -> np.ndarray:
        """z boundaries c_k of every look at level `alpha` (default: the design's)."""
        return _boundaries(self.fractions, self.alpha if alpha is None else alpha,
                           self.spending)

    def nominal_levels(self, alpha: float | None = None) -> np.ndarray:
        """Each look's boundary as a two-sided p-value: a look decides a claim when its
        t-test p-value is at most this (Jennison and Turnbull 2000, Sec. 11.4)."""
        from scipy.special import ndtr

        return 2 * ndtr(-self.boundaries(alpha))

    def look_of(self, seeds: int) -> int | None:
        """Index of the last look a claim whose rows have `seeds` seeds has reached (None
        before the first)."""
        reached = [k for k, s in enumerate(self.stages) if s <= seeds]
        return reached[-1] if reached else None

    def repeated_p_value(self, p, look: int):
        """The design's p-value of a look's nominal two-sided p-value `p` (scalar or
        array): the smallest level alpha' whose boundary at this look the statistic
        crosses, the repeated p-value of Jennison and Turnbull (2000, Sec. 9.1). Under no
        difference P(min over looks <= u) <= u for every u, whatever decides the looks
        that happen. Values that no level up to 0.5 reaches are reported as 1."""
        table = _level_table(self)[:, look]  # log nominal level at each of `_LEVELS`
        logp = np.log(np.clip(np.asarray(p, dtype=np.float64), 1e-300, 1.0))
        ok = np.isfinite(table)
        out = np.exp(np.interp(logp, table[ok], np.log(_LEVELS[ok])))
        return np.where(logp > table[ok][-1], 1.0, out)

    def describe(self) -> str:
        """The design in one sentence (for the ledger and the chapters)."""
        levels = ", ".join(f"{p:.3g}" for p in self.nominal_levels())
        name = {"obf": "O'Brien-Fleming", "pocock": "Pocock"}[self.spending]
        return (f"looks at {', '.join(map(str, self.stages))} seeds a row; {name}-type "
                f"alpha spending (Lan and DeMets 1983) at {self.alpha:g} two-sided per claim: "
                f"a look decides a claim when its t-test p-value is at most {levels}")


_TABLES: dict[SequentialDesign, np.ndarray] = {}


def _level_table(design: SequentialDesign) -> np.ndarray:
    """(levels, looks) log nominal p-value thresholds at each of `_LEVELS` (cached)."""
    from scipy.special import ndtr

    if design not in _TABLES:
        c = np.stack([_boundaries(design.fractions, a, design.spending) for a in _LEVELS])
        with np.errstate(divide="ignore"):
            table = np.log(2 * ndtr(-c))  # -inf where a look has nothing to spend
        table[~np.isfinite(table)] = -np.inf
        finite = np.where(np.isfinite(table), table, np.nan)
        for k in range(table.shape[1]):  # the map must be monotone to be inverted
            col = finite[:, k][~np.isnan(finite[:, k])]
            if np.any(np.diff(col) <= 0):
                raise ValueError(f"boundaries of look {k} are not monotone in the level")
        _TABLES[design] = np.where(np.isfinite(table), table, np.nan)
    return _TABLES[design]


def sequential_estimate(estimate: Estimate, design: SequentialDesign, look: int) -> Estimate:
    """`estimate` (computed on the first `design.stages[look]` seeds of each row) with its
    p-values (its components' too) replaced by the design's repeated p-values: what
    `decision_p_value` reads for the group-sequential test of one look."""
    def swap(e: Estimate) -> Estimate:
        p = None if e.p_value is None else float(design.repeated_p_value(e.p_value, look))
        return replace(e, p_value=p)

    return replace(swap(estimate), components=tuple(swap(c) for c in estimate.components))


def sequential_p_value(looks: Sequence[Estimate], direction: int, design: SequentialDesign
                       ) -> list[tuple[float, Verdict] | None]:
    """A claim's test at every look so far: looks[k] is its estimate on the first
    `design.stages[k]` seeds a row. Returns, per look, the running (p, side): the smallest
    of `decision_p_value` over the looks up to it, on repeated p-values (a best-of-k
    estimate combines its components' repeated p-values as `decision_p_value` does: the
    intersection-union max, or Bonferroni). None where no look up to it can be tested."""
    out: list[tuple[float, Verdict] | None] = []
    best = None
    for k, est in enumerate(looks):
        test = decision_p_value(sequential_estimate(est, design, k), direction)
        if test is not None and (best is None or test[0] < best[0]):
            best = test
        out.append(best)
    return out


def sequential_holm(p_by_look: Sequence[Sequence[float | None]], alpha: float = ALPHA
                    ) -> list[int | None]:
    """Holm's correction at every look: p_by_look[i][k] is claim i's running design p-value
    at look k (`sequential_p_value`; None: not tested). Returns, per claim, the first look
    at which Holm over every claim's p-value at that look rejects it (None: never). The
    running p-values only fall, so once rejected a claim stays rejected; this is the
    sequentially rejective group-sequential procedure of Maurer and Bretz (2013) for
    Holm's graph, with a claim's alpha passed on when it is rejected."""
    looks = max((len(p) for p in p_by_look), default=0)
    decided: list[int | None] = [None] * len(p_by_look)
    for k in range(looks):
        ps = [None if not p else p[min(k, len(p) - 1)] for p in p_by_look]
        for i, r in enumerate(holm(ps, alpha)):
            if r and decided[i] is None:
                decided[i] = k
    return decided


def _mde_arrays(va: np.ndarray, vb: np.ndarray, n, level, power: float) -> np.ndarray:
    """`minimum_detectable` at n seeds a row, vectorised over arrays of variances, seeds and
    two-sided levels (1 - `level` is the test's p-value threshold)."""
    from scipy.stats import t

    ua, ub = va / n, vb / n
    den = (ua * ua + ub * ub) / (n - 1)
    df = np.where(den > 0, (ua + ub) ** 2 / np.where(den > 0, den, 1.0), 2 * n - 2)
    return (t.ppf(0.5 + level / 2, df) + t.ppf(power, df)) * np.sqrt(ua + ub)


def stage_seeds_needed(var_a, var_b, effect, design: SequentialDesign, *,
                       power: float = POWER, max_seeds: int = 1000):
    """Seeds a row at which a claim reaches `power` against `effect` under the design: the
    first stage n_k whose boundary (`nominal_levels`) detects it (`minimum_detectable` at
    that level, Welch's df), else, past the last stage, the seeds at which the last look's
    level would (`seeds_needed` at that level); nan where even `max_seeds` does not or the
    effect is 0. Vectorised over var_a, var_b and effect."""
    va, vb, eff = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64)
                                        for x in (var_a, var_b, effect)))
    shape = va.shape
    va, vb, eff = va.ravel(), vb.ravel(), np.abs(eff.ravel())
    levels = design.nominal_levels()
    out = np.full(va.shape, np.nan)
    for n, a in zip(design.stages, levels, strict=True):
        hit = np.isnan(out) & (eff > 0) & (_mde_arrays(va, vb, n, 1 - a, power) <= eff)
        out[hit] = n
    # past the last stage: bisection on n at the last look's level, all claims at once
    rest = np.flatnonzero(np.isnan(out) & (eff > 0) & np.isfinite(eff))
    level = 1 - float(levels[-1])
    lo = np.full(rest.size, design.stages[-1] + 1)
    hi = np.full(rest.size, max(max_seeds, design.stages[-1] + 1))
    ok = _mde_arrays(va[rest], vb[rest], hi, level, power) <= eff[rest]
    while np.any(lo < hi):
        mid = (lo + hi) // 2
        fits = _mde_arrays(va[rest], vb[rest], mid, level, power) <= eff[rest]
        hi, lo = np.where(fits, mid, hi), np.where(fits, lo, mid + 1)
    out[rest] = np.where(ok, lo, np.nan)
    return out.reshape(shape)
