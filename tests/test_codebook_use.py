"""Table III's features are drawn evenly from every task, and the codebook rows of Tables I,
IV and Fig. 5 carry their codebook use (codes used of K and perplexity per seed), read from
features records measured on a simulator-free stand-in suite with freshly built tokenizers."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import fake_suite
from icil_paper.config import get_preset
from icil_paper.config_data import ConfigError
from icil_paper.eval.features import held_out_pieces, measure_features
from icil_paper.paper import table_spec
from icil_paper.paper.table_iii import feature_sampling_frame
from icil_paper.paper.table_iv import codes_used_frame
from icil_paper.records import features_record
from icil_paper.results import ResultsStore
from icil_paper.runspec import feature_key
from icil_paper.tables.assemble import assemble
from icil_paper.tables.cells import plan
from icil_paper.tables.definitions import CODEBOOK_TOKENIZERS
from icil_paper.tables.display import codebook_frame, show_codebook_use

SHARE = 9
"""Steps each fake task contributes: its held-out demos (2, 3, 4) hold 6, 8 and 13 steps,
so the share takes all of the first and 3 steps of the second."""


@pytest.fixture
def preset(monkeypatch):
    """The smoke preset on the fake suite's three tasks: 2 training demos a task, 3 held out,
    27 features (task order would take all 27 from the first task's held-out demos)."""
    fake_suite.use(monkeypatch)
    return get_preset("smoke").with_overrides(
        [f"data.robocasa_tasks={','.join(fake_suite.KITCHEN)}", "data.demos_per_task=2",
         "tables.feature_demos_per_task=3", f"tables.feature_steps={3 * SHARE}",
         "tables.icrt_seeds=2"])


def measure(preset, table_ids, rows=None):
    """Write the features record of every feature unit of the tables (of `rows` only, when
    given), measured on a freshly built tokenizer of the unit's run (no training)."""
    import torch

    from icil_paper.tokenizers import make_tokenizer

    store = ResultsStore(preset.name)
    specs = [table_spec(preset, t) for t in table_ids]
    if rows is not None:
        specs = [dataclasses.replace(s, rows=tuple(r for r in s.rows if r.label in rows))
                 for s in specs]
    for p in plan(specs):
        if not p.features:
            continue
        torch.manual_seed(p.run.seed)
        policy = SimpleNamespace(tokenizer=make_tokenizer(p.run.tokenizer, action_dim=7),
                                 device="cpu")
        for spec in p.features.values():
            store.run(*features_record(p.run, spec),
                      lambda spec=spec, policy=policy: measure_features(policy, spec, preset),
                      seed=p.run.seed)
    return store


# --------------------------------------------------------------------------- Table III sampling
def test_table_iii_scores_an_equal_share_of_every_task(preset):
    """Every unit of Table III (every row, every seed) scores SHARE steps of each task; the
    earlier task-order rule scored the first task only."""
    spec = table_spec(preset, "III")
    units = [u for row in spec.rows for u in row.entries["least_energy"].units]
    assert len({u.seed_index for u in units}) == 2
    assert len({feature_key(u.run, u.features) for u in units}) == len(units)  # one per run
    assert len({u.features for u in units}) == 1  # every seed scores the same steps
    pieces = held_out_pieces(units[0].features, preset)
    steps = {t: sum(len(p.actions) for p in pieces if p.task == t) for t in fake_suite.KITCHEN}
    assert steps == {t: SHARE for t in fake_suite.KITCHEN}
    assert [(p.task, p.demo, len(p.actions)) for p in pieces[:2]] == [
        (fake_suite.KITCHEN[0], 2, 6), (fake_suite.KITCHEN[0], 3, 3)]
    again = held_out_pieces(units[0].features, preset)  # deterministic
    assert [(p.task, p.demo, p.actions.tobytes()) for p in again] == [
        (p.task, p.demo, p.actions.tobytes()) for p in pieces]
    before = held_out_pieces(dataclasses.replace(units[0].features, sampling="task_order"),
                             preset)
    assert {p.task for p in before} == {fake_suite.KITCHEN[0]}


def test_a_short_task_gives_what_it_has_and_no_task_makes_up_for_it(preset):
    spec = table_spec(preset, "III").rows[0].entries["least_energy"].units[0].features
    pieces = held_out_pieces(dataclasses.replace(spec, steps=90), preset)  # shares of 30
    per_task = {t: sum(len(p.actions) for p in pieces if p.task == t) for t in fake_suite.KITCHEN}
    assert per_task == {t: 6 + 8 + 13 for t in fake_suite.KITCHEN}  # all three held-out demos
    with pytest.raises(ConfigError, match="at least 9"):
        dataclasses.replace(spec, steps=8)  # 2 steps a task: no least energy


def test_features_records_say_what_they_scored_and_the_chapter_shows_it(preset):
    store = measure(preset, ["III"], rows={"icrt+mlp", "icrt+lipvq"})
    result = assemble(table_spec(preset, "III"), store)
    cell = result.entry("icrt+lipvq", "least_energy")
    assert cell.estimate is not None and cell.data.shape == (2, 6)  # (seeds, trajectories)
    for m in cell.extra["metrics"]:
        assert m["tasks_scored"] == list(fake_suite.KITCHEN) == m["tasks"]
        assert m["steps_per_task"] == {t: SHARE for t in fake_suite.KITCHEN}
        assert m["trajectories_per_task"] == {t: 2 for t in fake_suite.KITCHEN}
        assert m["n_features"] == 3 * SHARE and m["n_trajectories"] == 6
        assert m["sampling"] == "per_task"
        assert 1 <= m["perplexity"] <= m["codes_used"] <= m["codebook_size"]
    assert "perplexity" not in result.entry("icrt+mlp", "least_energy").extra["metrics"][0]
    frame = feature_sampling_frame({"this build": result})
    assert len(frame) and set(frame["tasks scored"]) == {3} == set(frame["tasks"])
    assert set(frame["steps a task"]) == {str(SHARE)} and set(frame["trajectories"]) == {6}
    assert set(frame["features"]) == {3 * SHARE}


# --------------------------------------------------------------------------- codebook use
def test_codebook_rows_share_table_iii_records(preset):
    """The codebook cells of Tables I and IV are Table III's units for the same runs (no
    new measurement); Fig. 5's sizes other than Table I's are the only new ones."""
    keys = {t: {feature_key(u.run, u.features) for u in table_spec(preset, t).units()
                if u.features is not None} for t in ("I", "III", "IV", "fig5")}
    assert keys["I"] and keys["I"] <= keys["III"] and keys["IV"] <= keys["I"]
    assert len(keys["fig5"] - keys["I"]) == len(preset.tables.codebook_sizes) - 1
    for t in ("I", "IV", "fig5"):
        spec = table_spec(preset, t)
        for row in spec.rows:
            types = {u.run.tokenizer.type for u in row.entries["avg"].units if u.run.tokenizer}
            assert ("features" in row.entries) == bool(types & set(CODEBOOK_TOKENIZERS)), row.label
        assert "features" not in spec.columns and spec.beside == ("features",)


@pytest.mark.parametrize("table_id, rows, seeds", [
    ("I", ["icrt+vq", "icrt+lfq", "icrt+lipvq"], [0, 1]),
    ("IV", ["icrt+vq", "icrt+lipvq"], [0, 1]),
    ("fig5", None, None),  # every size: one seed, Table I's seeds at Table I's size
])
def test_the_codebook_frame_has_a_line_per_codebook_row_and_seed(preset, table_id, rows, seeds):
    spec = table_spec(preset, table_id)
    rows = rows or [r.label for r in spec.rows]
    empty = codebook_frame(assemble(spec, ResultsStore(preset.name)))
    assert set(empty["status"]) == {"not run"} and empty["codes used"].isna().all()
    store = measure(preset, [table_id])
    frame = codebook_frame(assemble(spec, store))
    if seeds is None:
        seeds_of = {r.label: sorted({u.seed_index for u in r.entries["avg"].units})
                    for r in spec.rows}
        assert sorted(len(s) for s in seeds_of.values()) == [1, 1, 1,
                                                            preset.tables.icrt_seeds]
    else:
        seeds_of = dict.fromkeys(rows, seeds)
    assert list(frame.index) == [(r, s) for r in rows for s in seeds_of[r]]
    assert (frame["status"] == "ok").all()
    assert ((1 <= frame["codes used"]) & (frame["codes used"] <= frame["K"])).all()
    assert ((1 <= frame["perplexity"]) & (frame["perplexity"] <= frame["codes used"])).all()
    if table_id == "fig5":
        assert sorted(set(frame["K"])) == sorted(preset.tables.codebook_sizes)


def test_fig5_counts_each_sizes_codes_used(preset, monkeypatch):
    shown = []
    monkeypatch.setattr("IPython.display.display", lambda *objects: shown.extend(objects))
    spec = table_spec(preset, "fig5")
    empty = {"this build": assemble(spec, ResultsStore(preset.name))}
    assert codes_used_frame(empty)["codes used"].isna().all()
    show_codebook_use(empty)
    assert [getattr(o, "data", None) for o in shown] == ["**the quick run (smoke)**: not run"]
    result = assemble(spec, measure(preset, ["fig5"]))
    used_frame = codes_used_frame({"this build": result})
    frame = codebook_frame(result)
    for row, lines in frame.groupby(level=0, sort=False):  # means over a row's seeds
        metrics = result.entry(row, "features").extra["metrics"]
        perplexity = np.mean([m["perplexity"] for m in metrics])
        used = lines["codes used"].mean()
        line = used_frame.loc[("the quick run (smoke)", row)]
        assert line["codes used"] == pytest.approx(used) and line["K"] == lines["K"].iloc[0]
        assert line["perplexity"] == pytest.approx(round(perplexity, 1))
    shown.clear()
    show_codebook_use({"this build": result})
    assert len(shown) == 1 and frame.to_html(classes="dataframe") in shown[0].data
    assert shown[0].data.startswith("<details") and f"({len(frame)} rows)" in shown[0].data
