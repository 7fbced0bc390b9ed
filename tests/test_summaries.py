"""The chapters' seed summaries (`icil_paper.book.studies`): means over seeds, intervals
and verdicts computed from the records a study stores; and the findings of chapters 02-05
built on them (`icil_paper.book.method`, `icil_paper.book.components`)."""

from __future__ import annotations

import numpy as np
import pytest

from icil_paper.book.studies import SeedRecords


def records():
    rng = np.random.default_rng(0)
    smooth = [rng.normal(1.0, 0.05, 30) for _ in range(3)]
    rough = [x + 0.5 for x in smooth]  # the same trajectories, every score 0.5 higher
    out = {}
    for label, per_seed in (("smooth", smooth), ("rough", rough)):
        out[label] = [{"least_energy": float(x.mean()), "least_energy_per_trajectory": list(x),
                       "usage": None if i == 0 else 0.1 * (i + 1), "name": f"{label}{i}",
                       "codes_used_per_level": [8, 4 + i]} for i, x in enumerate(per_seed)]
    return out


def test_means_are_over_the_seeds_that_recorded_the_value():
    seeds = SeedRecords(records())
    assert seeds.n_seeds == 3
    assert seeds.mean("smooth", "usage") == pytest.approx((0.2 + 0.3) / 2)  # seed 0 has None
    assert seeds.mean("smooth", "missing") is None
    assert seeds.per_level("smooth") == "8 / 5"
    row = seeds.seed_means()["rough"]
    assert row["least_energy"] == pytest.approx(np.mean([m["least_energy"]
                                                         for m in records()["rough"]]))
    assert row["name"] == "rough0"  # not a number: seed 0's


def test_scores_intervals_and_verdicts_follow_the_records():
    seeds = SeedRecords(records())
    assert seeds.scores("smooth", "least_energy").shape == (3, 30)
    text = seeds.with_interval("smooth", "least_energy")
    value, low, high = (float(x) for x in text.replace("[", "").replace("]", "")
                        .replace(",", "").split())
    assert low <= value <= high
    assert value == pytest.approx(seeds.scores("smooth", "least_energy").mean(), rel=1e-2)


def test_an_empty_label_is_refused():
    with pytest.raises(ValueError, match="no seed's record for \\['x'\\]"):
        SeedRecords({"x": []})


def _lipschitz_seed(empirical: float, bound: float = 2.0) -> dict:
    return {"empirical_inf_r0.1": empirical / 2, "empirical_inf_r1": empirical,
            "bound_inf": bound, "bound_2": 1.5, "bound_softplus_product": bound,
            "c_history": [[1.0, 2.0], [0.9, 2.2]], "history_step": [0, 100],
            "reconstruction_mse": 0.01}


def test_chapter_3_bound_check_flags_a_violated_bound():
    from icil_paper.book.method import BOUND_RTOL, bound_holds

    radii = (0.1, 1.0)
    assert bound_holds([_lipschitz_seed(2.0 * (1 + BOUND_RTOL / 2))], radii)  # float rounding
    assert not bound_holds([_lipschitz_seed(1.0), _lipschitz_seed(2.1)], radii)
