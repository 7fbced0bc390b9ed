"""The verdict rule is calibrated, has power, and its pieces (Holm, best of k, size, seeds
needed) do what their docstrings say.

The simulated rows follow Table I's design: 11 kitchen tasks x 10 episodes per seed, task
rates spread from 0 to 1 (some tasks at 0 or 1 for every row, as in our records), a
training seed that shifts every task's rate (spread 0.05, as measured between our seeds)
and scenes of varying difficulty (spread 0.2).
"""

from __future__ import annotations

import numpy as np
import pytest

from icil_paper.stats import (
    Estimate,
    adjusted_verdicts,
    decision_p_value,
    holm,
    magnitude,
    minimum_detectable,
    paired_difference,
    paired_margin,
    seed_variance,
    seeds_needed,
    verdict,
)
from simulated_rows import SCENE_SPREAD, SEED_SPREAD, TASK_RATES

EPISODES = 10
DECIDED = ("holds", "does not hold")


KINOVA_RATES = np.array([0.2, 0.5, 0.7, 0.9])
"""Table V's design: 4 Kinova tasks x 5 episodes per seed, where one seed's value moves in
steps of 0.05 and three seeds' differences are often all equal."""
KINOVA_EPISODES = 5


def _scenes(rng, sets: int, tasks: int = len(TASK_RATES), episodes: int = EPISODES
            ) -> np.ndarray:
    """(sets, tasks, episodes) scene difficulty shifts."""
    return rng.normal(0.0, SCENE_SPREAD, (sets, tasks, episodes))


def _row(rng, seeds: int, scenes: np.ndarray, shift: float = 0.0,
         rates: np.ndarray = TASK_RATES) -> np.ndarray:
    """Outcomes (seeds, tasks, episodes): seed s plays scene set s % len(scenes)."""
    seed_shift = rng.normal(0.0, SEED_SPREAD, (seeds, 1, 1))
    scene = scenes[np.arange(seeds) % len(scenes)]
    p = np.clip(rates[None, :, None] + shift + seed_shift + scene, 0.0, 1.0)
    return rng.random(p.shape) < p


def _decided_share(seeds_a: int, seeds_b: int, design: str, shift: float = 0.0,
                   trials: int = 1500, rng_seed: int = 0, rates: np.ndarray = TASK_RATES,
                   episodes: int = EPISODES) -> dict[str, float]:
    rng = np.random.default_rng(rng_seed)
    counts = {"holds": 0, "does not hold": 0, "inconclusive": 0, "too few seeds": 0}
    for _ in range(trials):
        sets = max(seeds_a, seeds_b) if design == "per_seed" else 1
        scenes = _scenes(rng, sets, len(rates), episodes)
        a = _row(rng, seeds_a, scenes, shift, rates)
        b = _row(rng, seeds_b, scenes, rates=rates)
        est = paired_difference(a, b, scenes=design, n_boot=200)
        counts[verdict(est)] += 1
    return {k: v / trials for k, v in counts.items()}


@pytest.mark.parametrize("design", ["shared", "per_seed"])
@pytest.mark.parametrize("seeds_a,seeds_b", [(1, 1), (3, 1), (3, 3), (10, 10)])
def test_no_difference_is_decided_at_most_about_five_percent(seeds_a, seeds_b, design):
    share = _decided_share(seeds_a, seeds_b, design)
    decided = share["holds"] + share["does not hold"]
    assert decided <= 0.065, share
    if min(seeds_a, seeds_b) == 1:
        assert share["too few seeds"] == 1.0  # a single-seed row is never decided
    else:
        assert share["holds"] <= 0.04 and share["does not hold"] <= 0.04, share
    if (seeds_a, seeds_b) == (10, 10):
        assert decided >= 0.02, share  # calibrated, not merely conservative


@pytest.mark.parametrize("seeds", [3, 10])
def test_no_difference_is_decided_at_most_about_five_percent_on_few_episodes(seeds):
    """Table V's design (20 episodes a seed, on scenes per seed index): per-seed values on
    a coarse grid, where equal differences must not make zero-width intervals."""
    share = _decided_share(seeds, seeds, "per_seed", rates=KINOVA_RATES,
                           episodes=KINOVA_EPISODES)
    assert share["holds"] + share["does not hold"] <= 0.065, share


def test_ten_seeds_a_row_detect_a_true_ten_point_difference():
    share = _decided_share(10, 10, "shared", shift=0.10, trials=400, rng_seed=1)
    assert share["holds"] >= 0.75, share
    assert share["does not hold"] == 0.0


def test_scenes_per_seed_are_paired_by_seed_index():
    rng = np.random.default_rng(3)
    scenes = _scenes(rng, 5)
    a, b = _row(rng, 5, scenes, shift=0.05), _row(rng, 5, scenes)
    paired = paired_difference(a, b, scenes="per_seed")
    welch = paired_difference(a, b, scenes="shared")
    assert "paired t on 5 seeds" in paired.method and paired.df == 4
    assert "welch" in welch.method and paired.value == welch.value
    with pytest.raises(ValueError, match="per_seed"):
        paired_difference(a, b, scenes="per-seed")


# ------------------------------------------------------------------------------------- holm

def test_holm_on_a_hand_computed_example():
    # m = 4: 0.005 <= 0.05/4, 0.01 <= 0.05/3, then 0.03 > 0.05/2 stops the procedure.
    assert holm([0.01, 0.04, 0.03, 0.005]) == [True, False, False, True]
    # Untested claims are not in the family: m = 2, 0.02 <= 0.025 and 0.04 <= 0.05.
    assert holm([0.02, None, 0.04]) == [True, False, True]
    assert holm([0.02, 0.9, 0.04]) == [False, False, False]  # 0.02 > 0.05/3
    assert holm([0.01, 0.9, 0.04]) == [True, False, False]  # then 0.04 > 0.05/2
    assert holm([]) == []


def test_adjusted_verdicts_keep_only_what_holm_rejects():
    def est(value, p, seeds=(5, 5)):
        return Estimate(value, value - 0.1, value + 0.1, sum(seeds), "t", seeds=seeds,
                        se=0.05, df=8.0, p_value=p)

    estimates = [est(0.2, 0.001), est(0.15, 0.04), est(-0.3, 0.002), est(0.1, 0.3),
                 est(0.4, 0.001, seeds=(5, 1)), None]
    adjusted = adjusted_verdicts(estimates, [1, 1, 1, 1, 1, 1])
    # Tested: p = 0.001, 0.04, 0.002, 0.3 (m = 4); 0.001 and 0.002 pass, 0.04 > 0.05/2.
    assert adjusted == ["holds", "inconclusive", "does not hold", "inconclusive",
                        "too few seeds", "not run"]


# --------------------------------------------------------------------------------- best of k

def _rows(rng, rates, seeds=10, tasks=4, episodes=50):
    out = []
    for r in rates:
        p = np.clip(r + rng.normal(0, 0.02, (seeds, 1, 1)), 0, 1)  # (seeds, 1, 1)
        out.append(rng.random((seeds, tasks, episodes)) < p)
    return out


def test_best_of_k_is_an_intersection_test():
    rng = np.random.default_rng(0)
    a, b, c = _rows(rng, [0.8, 0.5, 0.55])
    best = paired_margin(a, [b, c])
    assert best.value == pytest.approx(a.mean() - c.mean()) and len(best.components) == 2
    assert verdict(best) == "holds" and decision_p_value(best)[1] == "holds"
    # a beats b clearly but ties with c: not every pairwise interval is on the claimed side.
    a, b, c = _rows(rng, [0.6, 0.3, 0.6])
    assert verdict(paired_margin(a, [b, c])) == "inconclusive"
    # Some row beats a: does not hold.
    a, b, c = _rows(rng, [0.4, 0.45, 0.8])
    worse = paired_margin(a, [b, c])
    assert verdict(worse) == "does not hold" and decision_p_value(worse)[1] == "does not hold"
    # One row with a single seed: nothing is decided.
    a, b = _rows(rng, [0.9, 0.2])
    (c,) = _rows(rng, [0.2], seeds=1)
    assert verdict(paired_margin(a, [b, c])) == "too few seeds"


def test_best_of_k_under_no_difference_is_calibrated():
    """The old margin to the maximum of noisy rows made "does not hold" easy under no
    difference; the intersection test keeps each side at most about 2.5%."""
    rng = np.random.default_rng(4)
    counts = {"holds": 0, "does not hold": 0, "inconclusive": 0, "too few seeds": 0}
    trials = 600
    for _ in range(trials):
        scenes = _scenes(rng, 1)
        rows = [_row(rng, 3, scenes) for _ in range(6)]
        counts[verdict(paired_margin(rows[0], rows[1:]))] += 1
    assert counts["holds"] / trials <= 0.01  # must beat all five rows
    assert counts["does not hold"] / trials <= 0.04, counts


# ------------------------------------------------------------------------------ size, power

@pytest.mark.parametrize("low,high,direction,paper,expected", [
    (0.00, 0.02, +1, 0.05, "paper's size excluded"),
    (-0.10, 0.03, +1, 0.05, "paper's size excluded"),
    (0.01, 0.09, +1, 0.05, "consistent with the paper's size"),
    (0.08, 0.20, +1, 0.05, "beyond the paper's size"),
    (10.8, 24.1, -1, -1.71, "paper's size excluded"),  # claimed lower; ours is higher
    (-3.0, -2.0, -1, -1.71, "beyond the paper's size"),
])
def test_magnitude_against_the_papers_effect(low, high, direction, paper, expected):
    est = Estimate((low + high) / 2, low, high, 10, "t", seeds=(5, 5), se=0.01, df=8.0)
    assert magnitude(est, direction, paper) == expected


def test_magnitude_reports_equivalence_and_too_few_seeds():
    est = Estimate(0.006, -0.03, 0.04, 10, "t", seeds=(5, 5))
    assert magnitude(est, +1, 0.035, margin=0.05) == ("consistent with the paper's size; "
                                                      "within ±0.05 of 0")
    assert magnitude(est, +1, 0.035, margin=0.02) == "consistent with the paper's size"
    assert magnitude(est, +1, 0.041, margin=0.05) == "paper's size excluded; within ±0.05 of 0"
    one = Estimate(0.006, -0.03, 0.04, 4, "x", seeds=(3, 1))
    assert magnitude(one, +1, 0.041) == "too few seeds"


def test_seeds_needed_reach_the_planned_power_in_simulation():
    """At `seeds_needed` seeds a row, a true difference of the planned size is detected in
    about 80% of simulated experiments (the formula is a normal approximation)."""
    rng = np.random.default_rng(7)
    scenes = _scenes(rng, 1)
    pilot_a, pilot_b = _row(rng, 400, scenes, shift=0.06), _row(rng, 400, scenes)
    var_a, var_b = seed_variance(pilot_a), seed_variance(pilot_b)
    effect = float(pilot_a.mean() - pilot_b.mean())  # tasks at 0 or 1 clip part of the shift
    n = seeds_needed(var_a, var_b, effect)
    assert 3 <= n <= 40
    assert minimum_detectable(var_a, var_b, n, n) <= effect < minimum_detectable(
        var_a, var_b, n - 1, n - 1)
    hits, trials = 0, 300
    for _ in range(trials):
        est = paired_difference(_row(rng, n, scenes, shift=0.06), _row(rng, n, scenes))
        hits += verdict(est) == "holds"
    assert 0.65 <= hits / trials <= 0.95, (n, hits / trials)
    assert seeds_needed(var_a, var_b, 0.0) is None
    assert seeds_needed(var_a, var_b, 1e-4, max_seeds=50) is None
    with pytest.raises(ValueError, match="at least 2 seeds"):
        minimum_detectable(var_a, var_b, 1, 5)


def test_chapter_0_lists_each_undecided_claim_with_its_power():
    from icil_paper.book.report import undecided_power

    held = {"id": "a", "adjusted_verdict": "holds", "ours": 0.1, "ci": [0.05, 0.15]}
    open_ = {"id": "b", "adjusted_verdict": "inconclusive", "ours": 0.01, "ci": [-0.04, 0.06],
             "paper": 0.041, "power": 0.23, "mde": 0.071, "seeds_needed": 26}
    unplanned = {"id": "c", "adjusted_verdict": "too few seeds", "ours": 0.0, "ci": [-0.1, 0.1],
                 "paper": None, "reference_effect": None, "power": None, "mde": None,
                 "seeds_needed": None, "power_note": "no reference effect"}
    beyond = {"id": "d", "adjusted_verdict": "inconclusive", "ours": 0.02, "ci": [-0.03, 0.07],
              "paper": None, "reference_effect": 0.055, "power": 0.31, "mde": 0.098,
              "seeds_needed": 14}
    text = undecided_power([held, open_, unplanned, beyond])
    assert "**a**" not in text
    assert ("**d**: inconclusive, ours +0.020 [-0.030, +0.070]; power 31% to detect the "
            "reference +0.055 at these seeds; detects 0.098 with 80% power; 14 seeds a row "
            "would detect the reference effect") in text
    assert ("**b**: inconclusive, ours +0.010 [-0.040, +0.060]; power 23% to detect the "
            "paper's +0.041 at these seeds; detects 0.071 with 80% power; 26 seeds a row") in text
    assert "**c**: too few seeds" in text and "no reference effect" in text
    assert undecided_power([held]) == ""
