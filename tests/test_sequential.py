"""Seeds in stages: the group-sequential design spends its alpha as planned, its repeated
p-values invert its boundaries, its conditional power is the chance of crossing the last
boundary, and the whole procedure (looks, the graph at every look, rows that go on while
their conditional power at the observed effect is high enough) decides at most about 5% of
claims with no true difference while detecting a true +0.10 with fewer seeds, on average,
than a fixed design of the same power.

The simulated rows follow the reference run's kitchen design and measured spreads: 11 tasks
x 5 episodes per seed, a training seed that shifts every task's rate (spread 0.05), scenes
per seed index (seed k of every row on scene set k, difficulty spread 0.2), so that a
claim's test is the paired t on per-seed differences (`stats.paired_difference` with
scenes="per_seed"). The per-look t-tests are vectorised over trials here; a test checks
that they, and the claims' p-values, equal the library's on individual trials.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from scipy.stats import t as student

from icil_paper.stats import (
    ALPHA,
    SequentialDesign,
    best_of,
    decision_p_value,
    graph_test,
    paired_difference,
    seed_variance,
    sequential_graph,
)
from simulated_rows import SCENE_SPREAD, SEED_SPREAD, TASK_RATES

EPISODES = 5
DESIGN = SequentialDesign((5, 10, 15))


def _outcomes(rng, trials: int, shifts, seeds: int = 15) -> np.ndarray:
    """Bools (trials, rows, seeds, tasks, episodes); scene sets shared by seed index."""
    shifts = np.asarray(shifts, dtype=np.float32)[None, :, None, None, None]
    scene = rng.normal(0, SCENE_SPREAD, (trials, 1, seeds, len(TASK_RATES), EPISODES))
    seed = rng.normal(0, SEED_SPREAD, (trials, len(shifts[0]), seeds, 1, 1))
    p = np.clip(TASK_RATES[None, None, None, :, None] + shifts + seed + scene, 0, 1)
    return rng.random(p.shape, dtype=np.float32) < p


def _paired(va: np.ndarray, vb: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided paired-t p-values and signs of a - b on the first n seeds, (trials,)."""
    d = va[:, :n] - vb[:, :n]
    stat = d.mean(1) / (d.std(1, ddof=1) / np.sqrt(n))
    return 2 * student.sf(np.abs(stat), n - 1), np.sign(d.mean(1))


def _combine(ps: np.ndarray, signs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`decision_p_value` over arrays (others, trials): one difference as it is, best of k
    by the intersection-union max, or Bonferroni for "does not hold"."""
    if len(ps) == 1:
        return ps[0], signs[0]
    p_hold = np.where((signs > 0).all(0), ps.max(0), 1.0)
    p_against = np.minimum(1.0, len(ps) * np.where(signs <= 0, ps, np.inf).min(0))
    return np.minimum(p_hold, p_against), np.where(p_hold <= p_against, 1.0, -1.0)


def _simulate(outcomes: np.ndarray, claims, design: SequentialDesign = DESIGN,
              min_power: float = 0.1, budget: int | None = None, weights=None):
    """The whole procedure on every trial. claims: (a, (others...)) row indices, claimed
    above 0 (one other: a difference; several: best of k). After each look a claim's rows go
    on while its conditional power at the observed effect, at its level after the graph, is
    at least `min_power` (0: every undecided claim's rows go on, the worst case). budget: at
    most this many claims go on at a look, the first in claim order (the run's budget,
    `design.within_budget`). weights: the graph's (default: Holm's). Returns (sides
    (trials, claims): +1 holds, -1 does not hold, 0 undecided; decided look (trials,
    claims), -1 undecided; the rows' final seeds (trials, rows); the running p-values
    (trials, claims, looks))."""
    v = outcomes.mean(axis=(3, 4))  # (trials, rows, seeds): per-seed values
    trials, rows, _ = v.shape
    C, K = len(claims), len(design.stages)
    weights = np.full(C, 1 / C) if weights is None else np.asarray(weights)
    row_seeds = np.full((trials, rows), design.stages[0])
    running, run_side = np.full((trials, C), np.inf), np.zeros((trials, C))
    p_by_look = np.full((trials, C, K), np.nan)
    side, look = np.zeros((trials, C)), np.full((trials, C), -1)
    for k, n in enumerate(design.stages):
        nominal = np.ones((trials, C))
        looked = np.stack([row_seeds[:, [a, *o]].min(1) >= n for a, o in claims], axis=1)
        for c, (a, others) in enumerate(claims):
            tests = [_paired(v[:, a], v[:, o], n) for o in others]
            ps, signs = np.stack([p for p, _ in tests]), np.stack([s for _, s in tests])
            nominal[:, c] = _combine(ps, signs)[0]
            p, s = _combine(design.repeated_p_value(ps, k), signs)
            better = looked[:, c] & (p < running[:, c])
            running[better, c], run_side[better, c] = p[better], s[better]
        p_by_look[:, :, k] = running
        levels = np.zeros((trials, C))
        for i in range(trials):  # the graph over the claims at this look (the library's)
            rejected, w = graph_test([p if np.isfinite(p) else None for p in running[i]],
                                     weights)
            levels[i] = ALPHA * w
            fresh = rejected & (look[i] < 0)
            look[i, fresh], side[i, fresh] = k, run_side[i, fresh]
        if k == K - 1:
            break
        go = looked & (look < 0) & (design.conditional_power(nominal, k, levels) >= min_power)
        if budget is not None:
            go &= np.cumsum(go, axis=1) <= budget
        grow = np.zeros((trials, rows), dtype=bool)
        for c, (a, others) in enumerate(claims):
            grow[:, [a, *others]] |= go[:, [c]]
        row_seeds = np.where(grow & (row_seeds >= n), design.stages[k + 1], row_seeds)
    return side, look, row_seeds, p_by_look


# ------------------------------------------------------------------------------ the design

@pytest.mark.parametrize("spending", ["obf", "pocock"])
def test_boundaries_spend_the_planned_alpha_at_each_look(spending):
    design = SequentialDesign((5, 10, 15), spending=spending)
    c = design.boundaries()
    rng = np.random.default_rng(0)
    t = np.asarray(design.fractions)
    steps = rng.normal(size=(200_000, 3)) * np.sqrt(np.diff(np.r_[0.0, t]))
    z = steps.cumsum(1) / np.sqrt(t)  # the looks' z statistics under no difference
    cross = np.abs(z) >= c
    first = np.where(cross.any(1), cross.argmax(1), -1)
    planned = np.diff(np.r_[0.0, design.spent_alpha(t, ALPHA)])
    for k in range(3):
        share = np.mean(first == k)
        assert abs(share - planned[k]) < 4 * np.sqrt(planned[k] / 200_000) + 1e-4, (k, share)
    assert np.mean(first >= 0) == pytest.approx(ALPHA, abs=0.002)
    if spending == "obf":  # the first look is the normal quantile at the spent alpha
        assert c[0] == pytest.approx(1.959964 / np.sqrt(1 / 3), rel=1e-6)
        assert c[0] > c[1] > c[2] > 1.96  # strict early, close to a single look's at the end
        assert design.nominal_levels()[-1] > 0.04
    else:
        assert np.ptp(c) < 0.05  # Pocock: about the same boundary at every look


def test_repeated_p_values_invert_the_boundaries():
    for level in (1e-4, 0.001, 0.01, ALPHA, 0.2):
        nominal = DESIGN.nominal_levels(level)
        for k in range(3):
            assert DESIGN.repeated_p_value(nominal[k], k) == pytest.approx(level, rel=1e-3)
    p = np.geomspace(1e-12, 1, 50)
    for k in range(3):
        r = DESIGN.repeated_p_value(p, k)
        assert (np.diff(r) >= 0).all() and (r >= p * (1 - 1e-9)).all()  # never below nominal
    assert DESIGN.repeated_p_value(0.9, 2) == 1.0
    with pytest.raises(ValueError, match="increasing"):
        SequentialDesign((5, 5, 10))
    with pytest.raises(ValueError, match="spending"):
        SequentialDesign((5, 10), spending="haybittle")


def test_the_graph_at_every_look_passes_alpha_on():
    equal = [0.5, 0.5]
    # Look 0: 0.001 <= 0.05/2 is rejected, 0.04 is not; look 1: 0.04 <= 0.05/1.
    decided, levels = sequential_graph([[0.001, 0.001], [0.3, 0.04]], equal)
    assert decided == [0, 1] and levels[0].tolist() == [0.0, 0.05]
    # A running p-value never rises, and a claim with fewer looks carries its last one.
    assert sequential_graph([[0.01], [0.3, 0.2, 0.02]], equal)[0] == [0, 2]
    decided, levels = sequential_graph([[0.2, 0.2], [None, None]], equal)
    assert decided == [None, None] and levels[-1].tolist() == [0.05, 0.0]  # untested: left
    # weights: the primary claim's 0.8 share decides what a half share would not
    assert sequential_graph([[0.035], [0.5]], [0.8, 0.2])[0] == [0, None]
    assert sequential_graph([[0.035], [0.5]], equal)[0] == [None, None]


def test_conditional_power_is_the_chance_of_crossing_the_last_boundary():
    """At look 1 of (5, 10, 15) with the observed effect taken as the truth, simulated
    continuations cross the last boundary as often as `conditional_power` says."""
    rng = np.random.default_rng(1)
    t = DESIGN.fractions
    for p, alpha in ((0.01, ALPHA), (0.2, ALPHA), (0.01, 0.005)):
        z = -student.ppf(p / 2, 1e9)  # a look's |Z| from its two-sided p-value
        drift = z / np.sqrt(t[0])  # the observed effect, in units of the last look's se
        b_end = z * np.sqrt(t[0]) + drift * (1 - t[0]) + rng.normal(0, np.sqrt(1 - t[0]), 400_000)
        c_last = -student.ppf(DESIGN.nominal_level(alpha, 2) / 2, 1e9)
        assert DESIGN.conditional_power(p, 0, alpha) == pytest.approx(
            np.mean(b_end >= c_last), abs=0.003), (p, alpha)
    power = DESIGN.conditional_power(np.array([1e-4, 0.05, 0.5]), 1, ALPHA)
    assert power[0] > power[1] > power[2] and (DESIGN.conditional_power(0.01, 2, ALPHA) == 0)
    assert DESIGN.conditional_power(0.05, 0, 0.005) < DESIGN.conditional_power(0.05, 0, ALPHA)


# ------------------------------------------------------------------ the whole procedure

def test_the_simulation_computes_what_the_library_computes():
    """The vectorised t-tests, repeated p-values, best-of-k combination and the graph equal
    `paired_difference` / `best_of` + `SequentialDesign.p_values` + `sequential_graph`."""
    rng = np.random.default_rng(5)
    x = _outcomes(rng, 6, [0.06, 0.0, 0.0, 0.03])
    claims = [(0, (1,)), (3, (2,)), (0, (1, 2, 3))]
    side, look, _, p_by_look = _simulate(x, claims, min_power=0.0)  # every row goes on
    paired = partial(paired_difference, scenes="per_seed")
    for i in range(len(x)):
        runs = []
        for c, (a, others) in enumerate(claims):
            looks = []
            for n in DESIGN.stages:
                rows = [x[i, r, :n] for r in others]
                looks.append(paired(x[i, a, :n], rows[0]) if len(rows) == 1 else
                             best_of(x[i, a, :n], rows, paired))
            run = DESIGN.p_values(looks, +1)
            runs.append([p for p, _ in run])
            np.testing.assert_allclose([p for p, _ in run], p_by_look[i, c], rtol=1e-9)
        decided = sequential_graph(runs, np.full(3, 1 / 3))[0]
        assert [-1 if d is None else d for d in decided] == list(look[i])


@pytest.mark.parametrize("min_power", [0.1, 0.0])
def test_no_difference_is_decided_at_most_about_five_percent(min_power):
    """One claim, two rows, no true difference: through the looks at 5, 10 and 15 seeds,
    with rows that stop when their conditional power at the observed effect is below
    `min_power` (0: every row goes on, the worst case)."""
    rng = np.random.default_rng(11)
    side, look, seeds, _ = _simulate(_outcomes(rng, 3000, [0.0, 0.0]), [(0, (1,))],
                                     min_power=min_power)
    holds, against = np.mean(side == 1), np.mean(side == -1)
    assert holds + against <= 0.065 and holds <= 0.035 and against <= 0.035, (holds, against)
    if min_power == 0.0:
        assert holds + against >= 0.03  # calibrated, not merely conservative
        assert (seeds[look[:, 0] < 0] == 15).all()  # undecided rows went on to the end
    else:
        assert 0.2 < np.mean(seeds[:, 0] < 15) < 1, np.mean(seeds[:, 0] < 15)  # some stop early


def test_holm_over_a_ledger_keeps_the_familywise_level():
    """Table I's shape: LipVQ-VAE against five other rows (five differences and the best
    of k), one of them truly 0.3 worse: Holm at every look passes that claim's alpha on to
    the others, and a decision on any claim with no true difference (or against the truth)
    happens in at most about 5% of ledgers."""
    rng = np.random.default_rng(12)
    x = _outcomes(rng, 1500, [0.0, -0.3, 0.0, 0.0, 0.0, 0.0])
    claims = [(0, (1,)), (0, (2,)), (0, (3,)), (0, (4,)), (0, (5,)), (0, (1, 2, 3, 4, 5))]
    side, look, seeds, _ = _simulate(x, claims)
    assert np.mean(side[:, 0] == 1) > 0.95  # the true difference is decided
    wrong = (side[:, 1:] != 0).any(1) | (side[:, 0] == -1)
    assert wrong.mean() <= 0.065, wrong.mean()
    assert np.mean((look[:, 0] >= 0) & (look[:, 0] <= 1)) > 0.9  # by 10 seeds a row


def test_claims_the_budget_stops_keep_the_familywise_level():
    """Table I's shape with no true difference anywhere, and a budget that lets at most two
    undecided claims go on at each look: stopping claims can only lower the level."""
    rng = np.random.default_rng(14)
    x = _outcomes(rng, 1500, [0.0] * 6)
    claims = [(0, (r,)) for r in range(1, 6)] + [(0, (1, 2, 3, 4, 5))]
    side, _, seeds, _ = _simulate(x, claims, min_power=0.0, budget=2)
    wrong = (side != 0).any(1)
    assert wrong.mean() <= 0.065, wrong.mean()
    assert (seeds == 15).any() and (seeds[:, 1:] == 5).any()  # some went on, some stopped


def test_a_true_ten_point_difference_holds_with_fewer_seeds_than_a_fixed_design():
    rng = np.random.default_rng(13)
    x = _outcomes(rng, 3000, [0.14, 0.0])
    v = x.mean(axis=(3, 4))
    true = float((v[:, 0] - v[:, 1]).mean())
    assert 0.09 < true < 0.11  # tasks at 0 or 1 clip part of the shift: +0.10 remains
    side, look, seeds, _ = _simulate(x, [(0, (1,))])
    power = np.mean(side == 1)
    assert power >= 0.8 and np.mean(side == -1) == 0, power
    expected = seeds.mean()
    # the fixed design of the same power: the fewest seeds whose single look at 5% reaches
    # it on the same simulated rows (16: more than the 15 simulated)
    fixed = next((n for n in range(5, 16)
                  if np.mean(_paired(v[:, 0], v[:, 1], n)[0] <= ALPHA) >= power), 16)
    print(f"power {power:.3f}, expected seeds a row {expected:.2f}, fixed design {fixed}")
    assert expected < fixed and expected < 15, (expected, fixed, power)
    assert np.mean((look >= 0) & (look <= 1)) > 0.3  # many stop at 10 seeds or fewer


def test_library_variance_matches_the_stage_rule_reading():
    rng = np.random.default_rng(3)
    x = _outcomes(rng, 1, [0.0, 0.0])[0]
    assert seed_variance(x[0, :5]) == pytest.approx(x[0, :5].mean(axis=(1, 2)).var(ddof=1))
    est = paired_difference(x[0, :5], x[1, :5], scenes="per_seed")
    p, _ = _paired(x[None, 0].mean(axis=(2, 3)), x[None, 1].mean(axis=(2, 3)), 5)
    assert decision_p_value(est)[0] == pytest.approx(float(p[0]), rel=1e-9)


def test_the_ledger_records_the_look_of_each_decision(monkeypatch):
    """`claims._sequential`'s bookkeeping, on given running p-values: the look of each
    decision (a claim whose rows stopped at 5 seeds can still be decided when the graph
    passes it the level of a claim decided at 10), and for undecided claims whether their
    rows go on (conditional power at least the design's 0.1), stop, or were stopped by the
    budget."""
    from types import SimpleNamespace

    from icil_paper import stats
    from icil_paper.tables import claims as ledger_code
    from icil_paper.tables.design import Design

    runs = {"a": [(0.3, "holds"), (1e-4, "holds")],            # decided at its second look
            "b": [(0.012, "does not hold")],                    # rows stopped at 5 seeds
            "c": [(0.5, "holds"), (0.4, "holds")],              # high conditional power
            "d": [(0.5, "holds"), (0.4, "holds")],              # low conditional power
            "e": [(0.5, "holds"), (0.4, "holds")]}              # stopped by the budget
    nominal = {"a": 0.01, "b": 0.01, "c": 0.02, "d": 0.6, "e": 0.02}

    class Looks(SequentialDesign):
        def p_values(self, looks, direction):
            return runs[looks[0]][:len(looks)]

    monkeypatch.setattr(stats, "decision_p_value", lambda e, d: (nominal[e], "holds"))
    design = Design(dict.fromkeys(runs, "secondary"), dict.fromkeys(runs, 0.2),
                    Looks((5, 10, 15)), continuation_power=0.1)
    claims = [SimpleNamespace(id=i, direction=+1,
                              compare=SimpleNamespace(estimate=lambda t, i=i: i)) for i in runs]
    seeds = {"a": 10, "b": 5, "c": 10, "d": 10, "e": 10}
    entries = [{"id": i, "seeds": {"x": seeds[i], "y": 12}, "verdict": "inconclusive",
                "paper": None} for i in runs]
    ledger_code._sequential(claims, entries, {}, design, stops=("e",))
    a, b, c, d, e = entries
    assert a["look"] == "decided at look 2 of 3 (10 seeds a row)"
    assert a["sequential"]["decided_at"] == 10 and a["adjusted_verdict"] == "holds"
    assert b["look"].startswith("decided at look 1 of 3 (5 seeds a row), after the graph")
    assert b["adjusted_verdict"] == "does not hold" and b["sequential"]["decided_at"] == 5
    power = c["sequential"]["looks"][-1]["conditional_power"]
    assert power == pytest.approx(float(design.sequential.conditional_power(0.02, 1, 0.05 * 0.2 / 0.6)))
    assert power >= 0.1 and c["sequential"]["next"] == 15
    assert c["look"].startswith("undecided at 10 seeds (conditional power") and \
        c["look"].endswith("continues to 15") and c["adjusted_verdict"] == "inconclusive"
    assert d["sequential"]["next"] is None and "stops (conditional power" in d["look"]
    assert e["sequential"]["next"] is None and e["sequential"]["stopped_by"] == "budget"
    assert e["look"] == ("undecided at 10 seeds: stopped, 15 seeds a row are over the run's "
                         "budget")
    # the levels after the last look: a and b decided, their shares passed on
    assert c["sequential"]["level"] == pytest.approx(0.05 * 0.2 / 0.6)
