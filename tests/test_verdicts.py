"""The verdict rule is calibrated, has power, and its pieces (Holm and the graph, best of k,
size decisions, seeds needed) do what their docstrings say.

The simulated rows follow Table I's design: 11 kitchen tasks x 10 episodes per seed, task
rates spread from 0 to 1 (some tasks at 0 or 1 for every row, as in our records), a
training seed that shifts every task's rate (spread 0.05, as measured between our seeds)
and scenes of varying difficulty (spread 0.2).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import t as student

from icil_paper.stats import (
    Estimate,
    SequentialDesign,
    Size,
    adjusted_verdicts,
    best_of,
    decision_p_value,
    graph_test,
    holm,
    minimum_detectable,
    paired_difference,
    paired_variance_parts,
    repeated_interval,
    seed_variance,
    seeds_needed,
    size_decision,
    verdict,
    weighted_holm,
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
        est = paired_difference(a, b, scenes=design)
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
    best = best_of(a, [b, c], paired_difference)
    assert best.value == pytest.approx(a.mean() - c.mean()) and len(best.components) == 2
    assert verdict(best) == "holds" and decision_p_value(best)[1] == "holds"
    # a beats b clearly but ties with c: not every pairwise interval is on the claimed side.
    a, b, c = _rows(rng, [0.6, 0.3, 0.6])
    assert verdict(best_of(a, [b, c], paired_difference)) == "inconclusive"
    # Some row beats a: does not hold.
    a, b, c = _rows(rng, [0.4, 0.45, 0.8])
    worse = best_of(a, [b, c], paired_difference)
    assert verdict(worse) == "does not hold" and decision_p_value(worse)[1] == "does not hold"
    # One row with a single seed: nothing is decided.
    a, b = _rows(rng, [0.9, 0.2])
    (c,) = _rows(rng, [0.2], seeds=1)
    assert verdict(best_of(a, [b, c], paired_difference)) == "too few seeds"


def test_best_of_k_under_no_difference_is_calibrated():
    """The old margin to the maximum of noisy rows made "does not hold" easy under no
    difference; the intersection test keeps each side at most about 2.5%."""
    rng = np.random.default_rng(4)
    counts = {"holds": 0, "does not hold": 0, "inconclusive": 0, "too few seeds": 0}
    trials = 600
    for _ in range(trials):
        scenes = _scenes(rng, 1)
        rows = [_row(rng, 3, scenes) for _ in range(6)]
        counts[verdict(best_of(rows[0], rows[1:], paired_difference))] += 1
    assert counts["holds"] / trials <= 0.01  # must beat all five rows
    assert counts["does not hold"] / trials <= 0.04, counts


# ------------------------------------------------------------------------------ size, power

def _interval(low, high, df=8.0, seeds=(5, 5)):
    """An estimate whose 95% t interval is [low, high]."""
    se = (high - low) / 2 / student.isf(0.025, df)
    return Estimate((low + high) / 2, low, high, sum(seeds), "t", seeds=seeds, se=se, df=df)


@pytest.mark.parametrize("low,high,direction,paper,expected", [
    (0.00, 0.02, +1, 0.05, Size.SMALLER),
    (-0.10, 0.03, +1, 0.05, Size.SMALLER),
    (0.01, 0.09, +1, 0.05, Size.UNDECIDED),
    (0.08, 0.20, +1, 0.05, Size.LARGER),
    (10.8, 24.1, -1, -1.71, Size.SMALLER),  # claimed lower; ours is higher
    (-3.0, -2.0, -1, -1.71, Size.LARGER),
])
def test_size_decision_against_the_papers_effect(low, high, direction, paper, expected):
    assert size_decision(_interval(low, high), direction, paper, alpha=0.05) == expected


def test_size_decisions_widen_with_a_smaller_share_and_an_early_look():
    est = _interval(0.06, 0.16)  # decided "larger" than +0.05 at 5%
    assert size_decision(est, +1, 0.05, 0.05) == Size.LARGER
    assert size_decision(est, +1, 0.05, 0.005) == Size.UNDECIDED  # a claim's share of alpha
    design = SequentialDesign((5, 10, 15))
    low, high = repeated_interval(est.value, est.se, est.df, 0.05, design, look=0)
    assert low < est.low and high > est.high  # the first look's repeated interval is wider
    assert size_decision(est, +1, 0.05, 0.05, design, look=0) == Size.UNDECIDED
    assert size_decision(est, +1, None, 0.05) is None  # no number to read it against
    assert size_decision(_interval(0.06, 0.16, seeds=(5, 1)), +1, 0.05, 0.05) is None
    # best of k: larger only when every pairwise interval is; smaller when one is short
    pair = [_interval(0.06, 0.16), _interval(0.0, 0.03)]
    best = Estimate(0.01, 0.0, 0.03, 15, "best", seeds=(5, 5, 5), components=tuple(pair))
    assert size_decision(best, +1, 0.05, 0.05) == Size.SMALLER
    both = replace(best, components=(pair[0], pair[0]))
    assert size_decision(both, +1, 0.05, 0.05) == Size.LARGER


def test_repeated_intervals_cover_at_every_look_together():
    """Paired t intervals at the looks' nominal levels cover a true difference at all looks
    at once in about 1 - alpha of trials (the property the size decisions rest on)."""
    rng = np.random.default_rng(2)
    design = SequentialDesign((5, 10, 15))
    d = 0.03 + rng.normal(0, 0.05, (4000, 15))  # per-seed differences, true +0.03
    missed = np.zeros(len(d), bool)
    for k, n in enumerate(design.stages):
        se = d[:, :n].std(1, ddof=1) / np.sqrt(n)
        low, high = repeated_interval(d[:, :n].mean(1), se, n - 1, 0.05, design, k)
        missed |= (low > 0.03) | (high < 0.03)
    assert 0.03 <= missed.mean() <= 0.06, missed.mean()


def test_seeds_needed_reach_the_planned_power_in_simulation():
    """At `seeds_needed` seeds a row, a true difference of the planned size is detected in
    about 80% of simulated experiments (the formula is a normal approximation): with the
    unpaired variance for Welch's test on shared scenes, with the paired one for the paired
    test on scenes per seed index, which needs fewer seeds."""
    rng = np.random.default_rng(7)
    for design in ("shared", "per_seed"):
        scenes = _scenes(rng, 400 if design == "per_seed" else 1)
        pilot_a, pilot_b = _row(rng, 400, scenes, shift=0.06), _row(rng, 400, scenes)
        paired = design == "per_seed"
        var = (seed_variance(pilot_a, other=pilot_b) if paired
               else seed_variance(pilot_a) + seed_variance(pilot_b))
        effect = float(pilot_a.mean() - pilot_b.mean())  # tasks at 0 or 1 clip the shift
        n = seeds_needed(var, effect, paired=paired)
        assert 3 <= n <= 40
        assert minimum_detectable(var, n, paired=paired) <= effect < minimum_detectable(
            var, n - 1, paired=paired)
        hits, trials = 0, 300
        for _ in range(trials):
            sets = _scenes(rng, n) if paired else scenes
            est = paired_difference(_row(rng, n, sets, shift=0.06), _row(rng, n, sets),
                                    scenes=design)
            hits += verdict(est) == "holds"
        assert 0.65 <= hits / trials <= 0.95, (design, n, hits / trials)
        if paired:  # scene difficulty cancels from d_k (this model's seeds share nothing)
            assert n <= seeds_needed(seed_variance(pilot_a) + seed_variance(pilot_b), effect,
                                     paired=False)
    assert seeds_needed(var, 0.0) is None
    assert seeds_needed(var, 1e-4, max_seeds=50) is None
    with pytest.raises(ValueError, match="2 seeds"):
        minimum_detectable(var, 1)


# ------------------------------------------------------------------------------ the graph

def test_the_graph_with_equal_weights_is_holm_and_weights_shift_the_levels():
    rng = np.random.default_rng(0)
    for _ in range(200):
        p = rng.uniform(0, 0.06, 6) ** rng.uniform(1, 3)
        equal = graph_test(p, np.full(6, 1 / 6))[0]
        ranks = np.sort(p)
        steps = next((i for i, q in enumerate(ranks) if q > 0.05 / (6 - i)), 6)
        assert equal.sum() == steps and set(np.flatnonzero(equal)) == set(np.argsort(p)[:steps])
    # weighted Holm: 80% of alpha on two primary claims, 20% on four secondary ones
    w = [0.4, 0.4, 0.05, 0.05, 0.05, 0.05]
    rejected, left = graph_test([0.015, 0.5, 0.004, 0.5, 0.5, 0.5], w)
    # 0.015 <= 0.05 * 0.4 is rejected; its weight goes on in proportion: 0.004 <= 0.05 * 0.05
    # / 0.6 = 0.0042 is then rejected too; 0.5 is not
    assert rejected.tolist() == [True, False, True, False, False, False]
    assert left.sum() == pytest.approx(1.0) and left[1] == pytest.approx(0.4 / 0.55)
    # Holm's equal weights: 0.004 <= 0.05 / 6 is rejected, then 0.015 > 0.05 / 5 stops it
    assert graph_test([0.015, 0.5, 0.004, 0.5, 0.5, 0.5], np.full(6, 1 / 6))[0].tolist() == [
        False, False, True, False, False, False]
    g = weighted_holm(w)
    assert np.allclose(g.sum(1), 1) and np.allclose(np.diag(g), 0)
    # an untested claim leaves the graph and its weight goes on
    assert graph_test([None, 0.03], [0.5, 0.5])[0].tolist() == [False, True]
    assert graph_test([0.5, 0.03], [0.5, 0.5])[0].tolist() == [False, False]
    # a graph of Bretz et al. (2009): serial gatekeeping H1 -> H2 passes nothing until H1 goes
    serial = [[0, 1], [0, 0]]
    assert graph_test([0.04, 0.01], [1.0, 0.0], serial)[0].tolist() == [True, True]
    assert graph_test([0.06, 0.01], [1.0, 0.0], serial)[0].tolist() == [False, False]
    with pytest.raises(ValueError, match="summing to at most 1"):
        graph_test([0.01, 0.02], [0.8, 0.8])


def test_variance_parts_recover_the_simulated_seed_and_episode_noise():
    """Two rows with no difference and a seed spread of 0.05 on tasks away from 0 and 1: the
    paired per-seed difference has variance 2 * 0.05^2 + episode / E, the episode part being
    the noise of the paired episodes."""
    rng = np.random.default_rng(4)
    S, T, E = 400, 11, 5
    scenes, rates = _scenes(rng, S, T, E), np.full(T, 0.5)
    a, b = _row(rng, S, scenes, rates=rates), _row(rng, S, scenes, rates=rates)
    episode, seed_by_row = paired_variance_parts(a, b)
    d = a.reshape(S, -1).mean(1) - b.reshape(S, -1).mean(1)
    assert seed_by_row + episode / E == pytest.approx(d.var(ddof=1), rel=1e-9)
    assert seed_by_row == pytest.approx(2 * SEED_SPREAD**2, rel=0.3)
    assert seed_variance(a, other=b) == pytest.approx(d.var(ddof=1))
    with pytest.raises(ValueError, match="2 episodes"):
        paired_variance_parts(a[:, :1, :1], b[:, :1, :1])


def test_chapter_0_lists_each_undecided_claim_with_its_power():
    from icil_paper.book.report import ledger_frame

    held = {"id": "a", "adjusted_verdict": "holds", "ours": 0.1, "ci": [0.05, 0.15]}
    open_ = {"id": "b", "adjusted_verdict": "inconclusive", "ours": 0.01, "ci": [-0.04, 0.06],
             "paper": 0.041, "power": 0.23, "mde": 0.071, "seeds_needed": 26}
    unplanned = {"id": "c", "adjusted_verdict": "too few seeds", "ours": 0.0, "ci": [-0.1, 0.1],
                 "paper": None, "reference_effect": None, "power": None, "mde": None,
                 "seeds_needed": None, "power_note": "no reference effect"}
    beyond = {"id": "d", "adjusted_verdict": "inconclusive", "ours": 0.02, "ci": [-0.03, 0.07],
              "paper": None, "reference_effect": 0.055, "power": 0.31, "mde": 0.098,
              "seeds_needed": 14}
    frame = ledger_frame([held, open_, unplanned, beyond], "undecided")
    assert list(frame.index) == ["b", "c", "d"]
    assert frame.loc["d"].to_dict() == {
        "decided": "inconclusive", "ours": frame.loc["d", "ours"], "sized against": "+0.055",
        "power": "31%", "mde": "0.098", "seeds needed": 14, "note": ""}
    assert frame.loc["d", "ours"].replace("\u00a0", " ") == "+0.020 [-0.030, +0.070]"
    assert (frame.loc["b", "sized against"], frame.loc["b", "power"],
            frame.loc["b", "seeds needed"]) == ("+0.041", "23%", 26)
    assert frame.loc["c", "decided"] == "too few seeds"
    assert frame.loc["c", "note"] == "no reference effect" and frame.loc["c", "power"] == ""
    assert ledger_frame([held], "undecided").empty


def test_a_chapters_verdicts_collapse_the_quick_runs_below_the_reference_runs(monkeypatch):
    """The quick run tests the code, not the paper: its sentences sit in a closed <details>
    block after the reference run's, which stay open."""
    from types import SimpleNamespace

    from icil_paper.book import report
    from icil_paper.config import get_preset

    def ledger(p, store):
        return [SimpleNamespace(table="I", claim=f"claim of {p.name}", id=p.name)]

    monkeypatch.setattr(report, "claims_ledger", ledger)
    monkeypatch.setattr(report, "sentence", lambda e: f"said by {e.id}.")
    text = report.verdicts(get_preset("small"), "I")
    opened, closed = text.split("<details", 1)
    assert "claim of reference" in opened and "claim of small" not in opened
    assert "claim of small" in closed and closed.rstrip().endswith("</details>")
    alone = report.verdicts(get_preset("reference"), "I")
    assert "<details" not in alone and "claim of reference" in alone
