"""Intervals that cover, paired differences that pair, and the verdict rule."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from icil_paper.stats import (
    Estimate,
    best_of,
    paired_difference,
    paired_score_difference,
    rank_correlation,
    score_mean,
    success_rate,
    verdict,
    wilson_interval,
)

Z_95 = 1.959963984540054


def _simulate(rng, task_rates, seeds, episodes, seed_spread=0.0):
    """Outcomes (seeds, tasks, episodes); each seed shifts every task's rate by U(-s, s)."""
    rates = np.asarray(task_rates)[None, :] + rng.uniform(-seed_spread, seed_spread, (seeds, 1))
    rates = np.clip(rates, 0.0, 1.0)
    return rng.random((seeds, len(task_rates), episodes)) < rates[:, :, None]


# ---------------------------------------------------------------------------------- wilson

@pytest.mark.parametrize("k,n", [(0, 10), (3, 10), (5, 10), (10, 10), (17, 40)])
def test_wilson_endpoints_solve_the_score_equation(k, n):
    low, high = wilson_interval(k, n)
    p = k / n
    assert 0.0 <= low <= p <= high <= 1.0
    # Each endpoint p0 inside (0, 1) satisfies |p - p0| = z sqrt(p0 (1 - p0) / n).
    for p0 in (low, high):
        if 1e-12 < p0 < 1 - 1e-12:
            assert abs(p - p0) == pytest.approx(Z_95 * math.sqrt(p0 * (1 - p0) / n), rel=1e-9)


def test_wilson_without_episodes_is_uninformative():
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_one_seed_one_task_uses_wilson():
    outcomes = np.array([[[True] * 3 + [False] * 7]])
    est = success_rate(outcomes)
    assert (est.low, est.high) == wilson_interval(3, 10)
    assert est.value == pytest.approx(0.3) and est.n == 1 and est.episodes == 10
    assert "wilson" in est.method and est.seeds == (1,)


# -------------------------------------------------------------------------------- coverage

@pytest.mark.parametrize("seeds,tasks,episodes,seed_spread", [
    (1, 1, 30, 0.0),     # Wilson
    (1, 11, 10, 0.0),    # one seed: the stratified episode noise
    (3, 11, 10, 0.1),    # t on per-seed values, seeds that differ
])
def test_intervals_cover_the_true_rate(seeds, tasks, episodes, seed_spread):
    rng = np.random.default_rng(123)
    task_rates = np.linspace(0.15, 0.85, tasks) if tasks > 1 else np.array([0.35])
    truth = float(task_rates.mean())  # seed shifts have mean zero and never clip here
    covered, widths = 0, []
    for _ in range(200):
        est = success_rate(_simulate(rng, task_rates, seeds, episodes, seed_spread))
        covered += est.low <= truth <= est.high
        widths.append(est.high - est.low)
    assert 0.88 <= covered / 200 <= 0.995, covered
    assert np.mean(widths) < 0.5  # informative, not just [0, 1]


def test_more_episodes_narrow_the_interval():
    rng = np.random.default_rng(0)
    few = success_rate(_simulate(rng, [0.3, 0.6, 0.5], 1, 10))
    many = success_rate(_simulate(rng, [0.3, 0.6, 0.5], 1, 200))
    assert many.high - many.low < 0.5 * (few.high - few.low)


# ----------------------------------------------------------------- value, determinism, speed

def test_tasks_weigh_equally_and_seeds_average():
    outcomes = np.zeros((2, 3, 4), dtype=bool)
    outcomes[0, 0] = True  # seed 0: task 0 always succeeds -> 1/3
    outcomes[1, :, :2] = True  # seed 1: every task half -> 1/2
    assert success_rate(outcomes).value == pytest.approx((1 / 3 + 1 / 2) / 2)
    assert success_rate(outcomes.astype(int)).value == success_rate(outcomes).value


def test_intervals_draw_nothing_and_the_bootstrap_follows_its_seed():
    rng = np.random.default_rng(1)
    outcomes = _simulate(rng, np.linspace(0.2, 0.8, 11), 3, 10, 0.1)
    b = _simulate(np.random.default_rng(2), np.linspace(0.2, 0.8, 11), 1, 10)
    assert success_rate(outcomes[:1]) == success_rate(outcomes[:1])
    assert paired_difference(outcomes, b) == paired_difference(outcomes, b)
    rows = [_simulate(rng, [r] * 3, 3, 10) for r in (0.2, 0.4, 0.6, 0.8)]
    scores = [rng.normal(size=(3, 20)) for _ in rows]
    assert rank_correlation(scores, rows, rng_seed=7) == rank_correlation(scores, rows, rng_seed=7)
    assert rank_correlation(scores, rows, rng_seed=7) != rank_correlation(scores, rows, rng_seed=8)


def test_two_thousand_joint_resamples_are_fast():
    rng = np.random.default_rng(0)
    rows = [_simulate(rng, np.linspace(0.1, 0.9, 11), 5, 10, 0.1) for _ in range(6)]
    scores = [rng.normal(size=(5, 45)) for _ in rows]
    rank_correlation(scores, rows)  # warm-up (imports)
    start = time.perf_counter()
    rank_correlation(scores, rows, n_boot=2000)
    assert time.perf_counter() - start < 1.0


def test_estimate_round_trips_through_json():
    est = success_rate(_simulate(np.random.default_rng(0), [0.5, 0.4], 2, 8))
    d = json.loads(json.dumps(est.to_dict()))
    assert set(d) == {"value", "low", "high", "n", "method", "seeds", "episodes", "se", "df"}
    assert Estimate.from_dict(d) == est
    assert est.low <= est.value <= est.high and est.n == 2 and est.episodes == 2 * 2 * 8
    with pytest.raises(ValueError, match="reversed"):
        Estimate(0.5, 0.6, 0.4, 10, "x")
    with pytest.raises(ValueError, match="finite"):
        Estimate(float("nan"), 0.0, 1.0, 10, "x")
    with pytest.raises(AttributeError):
        est.value = 1.0  # frozen


# ------------------------------------------------------------------------ paired difference

def test_paired_difference_is_narrower_on_correlated_rows():
    rng = np.random.default_rng(5)
    # Scenes differ in difficulty; both rows succeed on easy scenes, row a a bit more often.
    difficulty = rng.random((11, 20))
    a = (difficulty < 0.6)[None]
    b = (difficulty < 0.5)[None]
    paired = paired_difference(a, b)
    assert paired.value == pytest.approx(a.mean() - b.mean())
    # Unpaired: each row's episode noise on its own, added.
    halves = [(r.high - r.low) / 2 for r in (success_rate(a), success_rate(b))]
    assert paired.high - paired.low < 0.6 * 2 * math.hypot(*halves)
    # a beats b on every scene where they differ, but one seed a row decides nothing.
    assert verdict(paired) == "too few seeds"


def test_paired_difference_allows_different_seed_counts():
    rng = np.random.default_rng(0)
    a = _simulate(rng, np.full(4, 0.8), 3, 15)
    b = _simulate(rng, np.full(4, 0.2), 1, 15)
    diff = paired_difference(a, b)
    assert diff.value == pytest.approx(a.mean() - b.mean())
    assert diff.n == 4 and diff.seeds == (3, 1) and diff.episodes == a.size + b.size
    assert diff.low > 0 and verdict(diff) == "too few seeds"  # b's seed variance is unknown
    same = paired_difference(a, a)
    assert same.value == 0.0 and same.low <= 0.0 <= same.high and "welch" in same.method
    assert verdict(same) == "inconclusive"


def test_paired_difference_of_identical_single_seed_rows_is_exactly_zero():
    a = _simulate(np.random.default_rng(0), [0.3, 0.7], 1, 12)
    est = paired_difference(a, a.copy())
    assert (est.value, est.low, est.high) == (0.0, 0.0, 0.0)
    assert verdict(est) == "too few seeds"


# ------------------------------------------------------------------------------ correlation

def test_rank_correlation_of_monotone_rows():
    rng = np.random.default_rng(0)
    rates = [0.1, 0.3, 0.5, 0.7, 0.9]
    energies = [5.0, 4.0, 3.0, 2.0, 1.0]  # smoother (lower energy) rows succeed more
    outcomes = [_simulate(rng, [r] * 3, 2, 40) for r in rates]
    scores = [e + 0.1 * rng.normal(size=(2, 50)) for e in energies]
    est = rank_correlation(scores, outcomes)
    assert est.value == pytest.approx(-1.0) and est.n == 5 and est.seeds == (2,) * 5
    assert verdict(est, direction=-1) == "holds" and est.p_value < 0.05
    one_seed = rank_correlation([s[0] for s in scores], outcomes)
    assert verdict(one_seed, direction=-1) == "too few seeds"


def test_rank_correlation_of_unrelated_rows_is_inconclusive():
    rng = np.random.default_rng(1)
    outcomes = [_simulate(rng, [0.5] * 3, 3, 10) for _ in range(5)]
    scores = [rng.normal(size=(3, 30)) for _ in range(5)]
    est = rank_correlation(scores, outcomes)
    assert -1.0 <= est.low <= est.value <= est.high <= 1.0
    assert verdict(est, direction=-1) == "inconclusive"


def test_rank_correlation_of_two_scores_and_its_bad_input():
    """Smoothness of the latents against the motion of the same rows' episodes: two kinds of
    scores, each row's seeds drawn once for both."""
    rng = np.random.default_rng(0)
    latents = [rng.normal(m, 0.3, size=(3, 30)) for m in range(4)]
    motion = [rng.normal(-m, 0.3, size=(3, 20)) for m in range(4)]
    est = rank_correlation(latents, motion, ("score", "score"))
    assert est.value == pytest.approx(-1.0) and est.high < 0 and est.p_value == 1 / 2000
    with pytest.raises(ValueError, match="at least 3 rows"):
        rank_correlation(latents[:2], motion[:2], ("score", "score"))
    with pytest.raises(ValueError, match="one x and one y per row"):
        rank_correlation(latents, motion[:3], ("score", "score"))
    with pytest.raises(ValueError, match="same tasks and episodes"):
        rank_correlation(latents, [*motion[:3], motion[3][:, :5]], ("score", "score"))
    with pytest.raises(ValueError, match="n_boot"):
        rank_correlation(latents, motion, ("score", "score"), n_boot=5)


# ---------------------------------------------------------------------------------- verdict

@pytest.mark.parametrize("low,high,direction,threshold,expected", [
    (0.02, 0.10, +1, 0.0, "holds"),
    (-0.10, -0.02, +1, 0.0, "does not hold"),
    (-0.05, 0.05, +1, 0.0, "inconclusive"),
    (0.0, 0.05, +1, 0.0, "inconclusive"),  # touching the threshold settles nothing
    (-0.10, -0.02, -1, 0.0, "holds"),
    (0.02, 0.10, -1, 0.0, "does not hold"),
    (0.10, 0.16, +1, 0.04, "holds"),       # e.g. a rate claimed above 0.04
    (0.00, 0.03, +1, 0.04, "does not hold"),
    (0.00, 0.03, -1, 0.04, "holds"),       # a rate claimed at most 0.04
])
def test_verdict(low, high, direction, threshold, expected):
    est = Estimate((low + high) / 2, low, high, 100, "test")
    assert verdict(est, direction, threshold) == expected


def test_verdict_rejects_a_bad_direction():
    with pytest.raises(ValueError, match="direction"):
        verdict(Estimate(0.1, 0.0, 0.2, 10, "test"), direction=2)


# ------------------------------------------------------------------------------ bad inputs

@pytest.mark.parametrize("bad,message", [
    (np.zeros((11, 10), dtype=bool), r"\(seeds, tasks, episodes\).*outcomes\[None\]"),
    (np.zeros(10, dtype=bool), r"shaped \(seeds, tasks, episodes\).*got shape \(10,\)"),
    (np.zeros((1, 0, 10), dtype=bool), "at least one seed, task and episode"),
    ([[[True, False], [True]]], "full"),
    (np.full((1, 2, 3), np.nan), "NaN"),
    (np.full((1, 2, 3), 0.5), "bools or 0/1"),
    (np.array([[["a", "b"]]]), "dtype"),
])
def test_bad_outcomes_raise_a_clear_error(bad, message):
    with pytest.raises(ValueError, match=message):
        success_rate(bad)


def test_bad_paired_shapes_and_arguments_raise():
    a = np.zeros((1, 11, 10), dtype=bool)
    with pytest.raises(ValueError, match=r"same \(tasks, episodes\).*\(11, 10\).*\(11, 8\)"):
        paired_difference(a, np.zeros((2, 11, 8), dtype=bool))
    with pytest.raises(ValueError, match="level"):
        success_rate(a, level=95)
    with pytest.raises(ValueError, match="NaN"):
        score_mean([1.0, np.nan])


def test_other_levels_change_the_width():
    outcomes = _simulate(np.random.default_rng(0), [0.4, 0.6], 1, 30)
    wide, narrow = success_rate(outcomes, level=0.99), success_rate(outcomes, level=0.8)
    assert narrow.high - narrow.low < wide.high - wide.low
    one = outcomes[:, :1]
    assert success_rate(one, level=0.8).high < success_rate(one).high  # Wilson, z for 80%


def test_margin_over_the_best_other_row():
    rng = np.random.default_rng(0)
    a = rng.random((1, 4, 50)) < 0.9
    b = rng.random((1, 4, 50)) < 0.5
    c = rng.random((1, 4, 50)) < 0.6
    m = best_of(a, [b, c], paired_difference)
    assert m.value == pytest.approx(a.mean() - c.mean()) and m.low > 0
    assert len(m.components) == 2 and m.seeds == (1, 1, 1)
    assert best_of(c, [a, b], paired_difference).high < 0
    one = best_of(a, [b], paired_difference)
    assert one.value == pytest.approx(paired_difference(a, b).value)
    scores = rng.random((3, 40))
    low = scores * 0.2  # lower is smoother (least energy): the lowest other row is the best
    s = best_of(low, [scores, scores + 1.0], paired_score_difference, sign=-1)
    assert s.value == pytest.approx(low.mean() - scores.mean()) and s.high < 0
    with pytest.raises(ValueError, match="same trajectories"):
        best_of(low[:, :10], [scores], paired_score_difference, sign=-1)
    with pytest.raises(ValueError, match="at least one other row"):
        best_of(low, [], paired_score_difference)


@pytest.mark.parametrize("outcome", [0, 1])
@pytest.mark.parametrize("seeds", [1, 3])
def test_a_row_that_always_fails_or_succeeds_is_not_known_exactly(outcome, seeds):
    """All 0 (or all 1) over several tasks: the bootstrap alone gives [0, 0]; the interval
    is at least the Wilson interval of all the row's episodes."""
    x = np.full((seeds, 4, 10), outcome, dtype=bool)
    row = success_rate(x)
    low, high = wilson_interval(outcome * x.size, x.size)
    assert row.value == outcome and row.high - row.low > 0.01
    assert row.low <= low + 1e-12 and row.high >= high - 1e-12


def test_seeds_equal_to_rounding_get_the_episode_noise_not_a_zero_width():
    """Three seeds, each one episode (of 20) apart on its own scenes: the per-seed
    differences are all -0.05 but differ in the 17th digit, which must not make a
    zero-width interval that decides the claim."""
    rng = np.random.default_rng(0)
    b = rng.random((3, 4, 5)) < 0.5
    a = b.copy()
    for k in range(3):
        t, e = np.argwhere(a[k])[0]
        a[k, t, e] = False
    per_seed = a.reshape(3, -1).mean(1) - b.reshape(3, -1).mean(1)
    assert np.allclose(per_seed, -0.05) and np.var(per_seed, ddof=1) > 0  # the rounding
    diff = paired_difference(a, b, scenes="per_seed")
    assert diff.high - diff.low > 0.1 and verdict(diff) == "inconclusive"


def test_one_episode_per_task_still_gets_an_interval():
    """Resampling within a task cannot vary a single episode; the tasks are pooled instead."""
    x = np.zeros((1, 11, 1), dtype=bool)
    x[0, 3, 0] = True
    est = success_rate(x)
    assert est.value == pytest.approx(1 / 11) and est.low < est.value < est.high
    y = np.zeros((1, 11, 1), dtype=bool)
    diff = paired_difference(x, y)
    assert diff.low <= 0 < diff.high  # one success in eleven episodes decides nothing
    assert verdict(diff) == "too few seeds"
    three = paired_difference(np.repeat(x, 3, axis=0), np.repeat(y, 3, axis=0))
    assert three.low <= 0 < three.high and verdict(three) == "inconclusive"


def test_episodes_per_seed_is_the_cheapest_narrowest_design():
    from icil_paper.stats import episodes_per_seed

    seed_var, episode_var, train_cost, episode_cost = 0.0016, 0.02, 200.0, 16.0
    best = episodes_per_seed(seed_var, episode_var, train_cost, episode_cost)

    def variance_times_cost(e):
        return (seed_var + episode_var / e) * (train_cost + e * episode_cost)

    grid = np.linspace(0.5, 50, 2000)
    assert abs(grid[np.argmin([variance_times_cost(e) for e in grid])] - best) < 0.05
    # seeds that differ more call for fewer episodes; dearer training for more
    assert episodes_per_seed(4 * seed_var, episode_var, train_cost, episode_cost) < best
    assert episodes_per_seed(seed_var, episode_var, 4 * train_cost, episode_cost) > best
    with pytest.raises(ValueError, match="seed_var"):
        episodes_per_seed(0.0, episode_var, train_cost, episode_cost)


def test_power_at_the_minimum_detectable_difference_is_the_planned_power():
    from icil_paper.stats import POWER, minimum_detectable, power_at

    for paired, var in ((True, 0.001), (False, 0.0025 + 0.004)):
        mde = minimum_detectable(var, 10, paired=paired)
        assert power_at(var, 10, mde, paired=paired) == pytest.approx(POWER, abs=1e-6)
        assert power_at(var, 10, mde / 2, paired=paired) < POWER < power_at(
            var, 10, 2 * mde, paired=paired)
        assert power_at(var, 20, mde, paired=paired) > POWER  # more seeds, more power
        # a smaller level (a claim's share of alpha) needs a larger difference
        assert minimum_detectable(var, 10, alpha=0.005, paired=paired) > mde
    # the paired test has fewer degrees of freedom at the same variance
    assert minimum_detectable(0.004, 5) > minimum_detectable(0.004, 5, paired=False)
    assert np.allclose(minimum_detectable(0.004, np.array([5, 10])),
                       [minimum_detectable(0.004, 5), minimum_detectable(0.004, 10)])
    with pytest.raises(ValueError, match="2 seeds"):
        power_at(0.0025, 1, 0.1)
