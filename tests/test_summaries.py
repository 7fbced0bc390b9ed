"""The chapters' seed summaries (`icil_paper.book.summaries`): means over seeds, intervals
and verdicts computed from the records a study stores; and the findings of chapters 02-05
built on them (`icil_paper.book.method`, `icil_paper.book.components`)."""

from __future__ import annotations

import numpy as np
import pytest

from icil_paper.book.summaries import SeedRecords


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


def test_chapter_4_reads_expert_measurements_written_by_hand_and_states_the_requirement(
        tmp_path):
    import json
    import os
    from pathlib import Path

    import pandas as pd

    from icil_paper.book.components import demonstration_findings
    from icil_paper.book.studies import expert_measurements
    from icil_paper.config import get_preset

    preset = get_preset("smoke")  # data.expert_seeds = 0: the preset measures nothing itself
    folder = Path(os.environ["ICIL_RESULTS"]) / "experts"
    folder.mkdir(parents=True)
    task = {"episodes": 50, "expert_success_rate": 0.86, "replay_success_rate": 1.0,
            "mean_length": 120.0}
    (folder / "kinova.json").write_text(json.dumps({"tasks": {"kinova/open_drawer": task},
                                                       "git_commit": "abcdef0123"}))
    rows = expert_measurements(preset)
    assert rows == [{"task": "kinova/open_drawer", "seeds": 50, "expert": 0.86,
                     "expert, human scenes": None, "replay": 1.0, "human kept": None,
                     "mean length": 120.0, "from": "abcdef01"}]
    kept = pd.DataFrame({"generated: success over data-set scenes": [0.95, 1.0]},
                        index=["kinova/open_drawer", "kinova/close_drawer"])
    summary = pd.DataFrame(
        [{"task": "kinova/open_drawer", "source": s, "mean_length": n, "still_fraction": still,
          "least_energy_per_step": e}
         for s, n, still, e in (("generated", 100, 0.1, 1.0), ("human", 150, 0.3, 2.0))]
    ).set_index(["task", "source"])
    text = demonstration_findings({"kinova/open_drawer": {"success": True}}, kept,
                                  pd.DataFrame(rows), summary, ["kinova/open_drawer"], "smoke")
    assert "succeeded on 1 of 1 shown tasks." in text
    assert "every task meets 0.9 there." in text
    assert "ranges from 0.86 to 0.86; below 0.9: ['kinova/open_drawer']." in text
    assert "human demos are 1.50x as long" in text and "(less smooth, as" in text
