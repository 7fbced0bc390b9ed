"""The reference run's design and cost: the seeds each row gets follow the power rule for
the ledger's `seeds_needed`, and what a run cost is summed from its records."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import pytest

from icil_paper.config import get_preset
from icil_paper.paper import table_spec
from icil_paper.planning.cost import run_cost
from icil_paper.planning.design import (
    DECIDABLE_SEEDS,
    OTHER_SEEDS,
    TABLE_IDS,
    claim_rows,
    design_frame,
    design_ledger,
    design_problems,
    planned_seeds,
)
from icil_paper.planning.staged import as_run
from icil_paper.records import train_record
from icil_paper.results import ResultsStore
from record_helpers import write_eval_record

ROOT = Path(__file__).resolve().parents[1]
TASKS = "data.robocasa_tasks=kitchen/open_drawer,kitchen/close_drawer,kitchen/open_door"


def smoke(*overrides):
    return get_preset("smoke").with_overrides([TASKS, *overrides])


def test_a_decidable_claim_asks_ten_seeds_of_every_row_it_reads():
    preset = smoke("tables.icrt_seeds=5", "tables.baseline_seeds=5")
    rows = claim_rows(preset)["I-tokenizer-gap"]
    assert rows == (("I", "icrt+lipvq"), ("I", "icrt+mlp"))
    ledger = {"I-tokenizer-gap": {"seeds_needed": 6}}
    problems = [p for p in design_problems(preset, ledger) if p.startswith("I-tokenizer-gap")]
    assert len(problems) == 2 and f"asks {DECIDABLE_SEEDS}" in problems[0]
    more = smoke("tables.icrt_seeds=5", "tables.baseline_seeds=5",
                 "tables.row_seeds=I:icrt+lipvq=10,I:icrt+mlp=10")
    assert not [p for p in design_problems(more, ledger) if p.startswith("I-tokenizer-gap")]
    # an undecidable claim asks only OTHER_SEEDS
    assert not [p for p in design_problems(preset, {"I-tokenizer-gap": {"seeds_needed": 40}})
                if p.startswith("I-tokenizer-gap")]
    few = smoke("tables.icrt_seeds=2")
    assert any(f"asks {OTHER_SEEDS}" in p for p in design_problems(few, {}))


def test_the_reference_preset_follows_the_rule_for_its_ledger(tmp_path):
    """The fixed seeds a row were set by the rule from the ledgers there were when the design
    was registered: the kitchen run's and the older protocol's (the run they planned has its
    own ledger now, and a design is not changed by the data it judges)."""
    preset = get_preset("reference")
    registered = tmp_path / "reference"
    older = ROOT / "results" / "reference" / "older-code"
    (registered / "older-code").mkdir(parents=True)
    shutil.copy(older / "kitchen" / "claims.json", registered / "claims.json")
    shutil.copy(older / "claims.json", registered / "older-code" / "claims.json")
    ledger = design_ledger(preset, root=tmp_path)
    assert ledger["I-tokenizer-gap"]["seeds_needed"] is not None
    assert design_problems(preset, ledger) == []
    seeds = planned_seeds(preset)
    assert seeds["I", "icrt+lipvq"] >= DECIDABLE_SEEDS and seeds["I", "bc_transformer"] >= 10
    assert min(seeds[r] for rows in claim_rows(preset).values() for r in rows) >= OTHER_SEEDS
    assert preset.tables.scenes_per_seed  # seeds are evaluated on scene sets of their own
    fixed = design_frame(replace(preset, tables=replace(preset.tables, seed_stages=())))
    assert list(fixed.index) == list(claim_rows(preset))
    assert (fixed["planned"] >= fixed["required"]).all()


def test_chapter_00s_design_table_shows_the_seeds_of_the_stage_the_run_reached(
        tmp_path, monkeypatch):
    # the committed ledgers (the power analysis) but no record: the run's first stage
    for name in ("claims.json", "older-code/claims.json"):
        (tmp_path / "reference" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "reference" / name).write_text(
            (ROOT / "results" / "reference" / name).read_text())
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path))
    preset = get_preset("reference")
    frame = design_frame(as_run(preset))
    assert list(frame.index) == list(claim_rows(preset))
    assert "required" not in frame and "planned" not in frame
    assert (frame["stage"] == preset.tables.seed_stages[0]).all()
    assert (frame["finished"] == 0).all()
    # the half-width is expected at the stage's 5 seeds: wider than at the fixed design's
    # 10 for the rows that had 10, the same for those that had 5
    fixed = design_frame(replace(preset, tables=replace(preset.tables, seed_stages=())))
    both = frame["expected ±"].ne("") & fixed["expected ±"].ne("")
    stage, planned = frame["expected ±"][both].astype(float), fixed["expected ±"][both].astype(float)
    assert (stage >= planned).all()
    assert (stage > planned).sum() == (fixed["planned"][both] > 5).sum() > 0


def test_the_cost_sums_each_records_time_under_its_stage_and_kind(tmp_path):
    preset = smoke()
    store = ResultsStore(preset.name, root=tmp_path)
    unit = table_spec(preset, "I").row("icrt+lipvq").entries["avg"].units[0]
    episodes = [{"success": True, "steps": 5}] * 2
    write_eval_record(store, unit, episodes, 5.0)
    store.write(*train_record(unit.run), {"steps": 5}, seed=0, wall_time_s=10.0, cpu_time_s=18.0)
    stray = train_record(unit.run.replace(seed=99))  # a run no table plans: older code
    store.write(*stray, {"steps": 5}, seed=99, wall_time_s=4.0, cpu_time_s=4.0)
    cost = json.loads(json.dumps(run_cost(preset, store)))
    assert cost["by_stage"]["table-I"]["records"] == 2
    kitchen = cost["by_kind"]["icrt kitchen state"]
    assert kitchen["cells"] == 1 and kitchen["train_steps"] == 5 and kitchen["episodes"] == 2
    assert cost["total"]["wall_s"] == 10.0 and cost["older_code"]["records"] == 1
    assert cost["finished_cells"] == 1 and cost["planned_cells"] == len(
        {u.run.key() for t in TABLE_IDS for u in table_spec(preset, t).units()})
    assert cost["total"]["without_cpu_time"] == 1 and cost["total"]["cpu_per_wall"] is None
    assert len(cost["sittings"]) == 1 and cost["sittings"][0]["records"] == 2


def test_chapter_02s_run_counts_as_a_cell_of_its_table_stage(tmp_path):
    """Chapter 02's run is the `icrt` table's one cell: planned and priced under the stage
    `table-icrt` as an ICRT cell, one more planned cell than the paper's tables have."""
    preset = smoke()
    store = ResultsStore(preset.name, root=tmp_path)
    [unit] = table_spec(preset, "icrt").units()
    write_eval_record(store, unit, [{"success": True, "steps": 5}], 5.0)
    store.write(*train_record(unit.run), {"steps": 5}, seed=0, wall_time_s=10.0, cpu_time_s=9.0)
    cost = run_cost(preset, store)
    assert cost["by_stage"]["table-icrt"]["records"] == 2 and "icrt" not in cost["by_stage"]
    assert cost["by_kind"]["icrt metaworld state"]["cells"] == 1
    group = cost["projection"]["groups"]["table-icrt / icrt metaworld state"]
    assert group["planned_cells"] == group["finished_cells"] == 1
    papers = {u.run.key() for t in TABLE_IDS if t != "icrt" for u in table_spec(preset, t).units()}
    assert cost["planned_cells"] == len(papers) + 1 and cost["older_code"]["records"] == 0


def test_expected_half_width_shrinks_with_seeds_and_matches_the_ledgers_own():
    from scipy.stats import t

    from icil_paper import stats
    from icil_paper.planning.design import expected_half_width

    var = 0.0025
    mde = stats.minimum_detectable(2 * var, 3, paired=False)  # an older ledger: Welch at 5%
    entry = {"mde": mde, "seeds": {"a": 3, "b": 3}}
    at_3 = expected_half_width(entry, 3)
    assert at_3 == pytest.approx(t.ppf(0.975, 4) * (2 * var / 3) ** 0.5, rel=1e-6)
    assert expected_half_width(entry, 10) < at_3
    # a one-seed row: read back from seeds_needed for the paper's effect
    needed = stats.seeds_needed(2 * var, 0.088, paired=False)
    from_needed = expected_half_width({"seeds_needed": needed, "paper": 0.088,
                                       "seeds": {"a": 3, "b": 1}}, 10)
    assert from_needed == pytest.approx(expected_half_width(entry, 10), rel=0.15)
    assert expected_half_width({"seeds": {"a": 1}}, 10) is None
    # an entry that states its plan: the variance its (paired) test reads
    planned = {"plan": {"variance": var, "paired": True, "level": 0.0067}, "mde": 1.0}
    assert expected_half_width(planned, 5) == pytest.approx(t.ppf(0.975, 4) * (var / 5) ** 0.5)


def test_run_progress_counts_the_cells_done_and_the_projection(tmp_path):
    from icil_paper.book.report import run_progress

    path = tmp_path / "cost.json"
    sittings = [{"elapsed_s": 3600.0}, {"elapsed_s": 1800.0}]
    path.write_text(json.dumps({"finished_cells": 12, "planned_cells": 370,
                                "sittings": sittings}))
    p = run_progress(path)
    assert (p["finished"], p["planned"], p["sittings"]) == (12, 370, 2)
    assert p["hours"] == pytest.approx(1.5) and p["wall_hours"] is None  # no projection
    path.write_text(json.dumps({"finished_cells": 12, "planned_cells": 370,
                                "sittings": sittings, "projection": {"wall_hours_at_2": 9.24,
                                                                     "target_wall_hours": 12.0}}))
    p = run_progress(path)
    assert (p["wall_hours"], p["target_hours"], p["more_stages"]) == (9.24, 12.0, False)
    staged = {"stages": [5, 10, 15], "looks": [{"seeds": 5, "going_on": ["I:bin"]}]}
    path.write_text(json.dumps({**json.loads(path.read_text()), "stages": staged}))
    assert run_progress(path)["more_stages"]
    staged["looks"][0]["going_on"] = []  # the look sent nothing on: the run is whole
    path.write_text(json.dumps({**json.loads(path.read_text()), "stages": staged}))
    assert not run_progress(path)["more_stages"]
    assert run_progress(tmp_path / "none") is None


def test_decisions_per_cpu_hour_are_read_from_each_runs_ledger_and_cost(tmp_path, monkeypatch):
    from icil_paper.book import report

    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path))
    store = ResultsStore("reference").dir
    (store / "older-code").mkdir(parents=True)
    claim = {"id": "x", "verdict": "holds", "adjusted_verdict": "holds"}
    undecided = {"id": "y", "verdict": "inconclusive", "adjusted_verdict": "inconclusive"}
    for folder, claims, cpu_s in ((store / "older-code", [claim] * 6 + [undecided], 79200.0),
                                  (store, [claim] * 3 + [undecided] * 4, 36000.0)):
        (folder / "claims.json").write_text(json.dumps({"claims": claims}))
        (folder / "cost.json").write_text(json.dumps({"total": {"cpu_s": cpu_s}}))
    assert report.decision_rate(store) == (3, pytest.approx(10.0), False)
    assert report.decision_rate(store / "older-code") == (6, pytest.approx(22.0), False)
    (store / "cost.json").write_text(json.dumps({"total": {"cpu_s": 36000.0},
                                                 "finished_cells": 9, "planned_cells": 9}))
    assert report.decision_rate(store)[2]  # finished
    (store / "cost.json").unlink()
    assert report.decision_rate(store) is None


def test_each_earlier_runs_decision_stands_beside_this_runs(tmp_path, monkeypatch):
    """`earlier_verdicts` puts each claim's decision (with a decided size) beside the
    decision of every earlier run that kept a ledger, blank where that run lacked the claim."""
    from icil_paper.book import report

    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path))
    store = ResultsStore("reference").dir
    kitchen, older = (store / run.folder for run in report.EARLIER_RUNS)
    kitchen.mkdir(parents=True)
    made_by = {"commit": "e" * 40, "why_kept": "a record of that protocol"}
    (kitchen / "claims.json").write_text(json.dumps({"made_by": made_by, "claims": [
        {"id": "x", "verdict": "does not hold", "adjusted_verdict": "does not hold"}]}))
    (older / "claims.json").write_text(json.dumps({"made_by": made_by, "claims": [
        {"id": "x", "verdict": "holds", "adjusted_verdict": "inconclusive"},
        {"id": "y", "verdict": "holds", "adjusted_verdict": "holds"}]}))
    ours = [{"id": "x", "verdict": "holds", "adjusted_verdict": "holds",
             "size": "smaller than the paper's effect"},
            {"id": "y", "verdict": "inconclusive", "adjusted_verdict": "inconclusive"}]
    frame = report.earlier_verdicts(ours)
    assert list(frame.columns) == ["this run", "the kitchen run", "the older protocol's run"]
    assert frame.loc["x"].tolist() == ["holds, smaller than the paper's", "does not hold",
                                       "inconclusive"]
    assert frame.loc["y"].tolist() == ["inconclusive", "", "holds"]


def test_each_look_shows_the_seeds_its_rows_had_and_the_rows_it_sent_on():
    from icil_paper.book.report import looks_frame

    record = {"looks": [
        {"seeds": 5, "rows": {"I:icrt+lipvq": 5, "I:bc_transformer": 5, "II:act": 5},
         "going_on": {"I:icrt+lipvq": 10, "I:bc_transformer": 10}, "over_budget": ["II-x"]},
        {"seeds": 10, "rows": {"I:icrt+lipvq": 10, "I:bc_transformer": 9}, "going_on": {}}]}
    frame = looks_frame(record)
    assert frame["look at"].tolist() == ["5 seeds", "10 seeds"]
    assert frame["rows read"].tolist() == [3, 2]
    assert frame["their seeds"].tolist() == ["5", "9–10"]
    assert frame["rows going on"].tolist() == ["I:icrt+lipvq, I:bc_transformer", "none"]
    assert frame["to seeds"].tolist() == ["10", ""]
    assert frame["stopped by the budget"].tolist() == ["II-x", ""]
    assert looks_frame(None).empty


def test_a_staged_runs_cost_is_bounded_by_its_stages(tmp_path):
    from icil_paper.planning.cost import stages_cost

    preset = get_preset("small").with_overrides(  # on this file's tasks: smaller plans
        [TASKS, "tables.icrt_seeds=6", "tables.baseline_seeds=6", "tables.seed_stages=2,8"])
    cost = stages_cost(preset, ResultsStore(preset.name, root=tmp_path))
    assert cost["stages"] == [2, 8] and cost["looks"] == []  # nothing stored: the first stage
    assert (0 < cost["reached_wall_hours_at_2"] < cost["fixed_design_wall_hours_at_2"]
            < cost["last_stage_wall_hours_at_2"])


def test_the_projection_prices_unfinished_cells_at_their_measured_rate(tmp_path):
    preset = smoke()
    store = ResultsStore(preset.name, root=tmp_path)
    unit = table_spec(preset, "I").row("icrt+lipvq").entries["avg"].units[0]
    store.write(*train_record(unit.run), {"steps": 5}, seed=0, wall_time_s=10.0, cpu_time_s=18.0)
    projection = run_cost(preset, store)["projection"]
    group = projection["groups"]["table-I / icrt kitchen state"]
    assert group["finished_cells"] == 1 and group["rate_from"] == "records"
    assert group["cpu_s_per_cell"] == 18.0
    assert group["remaining_cpu_s"] == (group["planned_cells"] - 1) * 18.0
    estimated = [g for g in projection["groups"].values() if g["rate_from"] == "cells.json"]
    assert estimated and all(g["finished_cells"] == 0 for g in estimated)
    total_s = sum(g["remaining_cpu_s"] for g in projection["groups"].values())
    assert projection["remaining_cpu_hours"] == pytest.approx(total_s / 3600, abs=0.01)
    assert projection["wall_hours_at_2"] == pytest.approx(projection["cpu_hours"] / 2, abs=0.01)
    assert 0 < projection["from_records"] < 1


def test_a_resumed_cell_does_not_lower_the_training_rate(tmp_path):
    preset = smoke("tables.icrt_seeds=2")
    store = ResultsStore(preset.name, root=tmp_path)
    units = [entry.units for entry in [table_spec(preset, "I").row("icrt+lipvq").entries["avg"]]][0]
    fresh, resumed = sorted({u.run.seed: u.run for u in units}.values(), key=lambda r: r.seed)
    store.write(*train_record(fresh), {"steps": 5, "resumed_from_step": 0}, seed=fresh.seed,
                wall_time_s=20.0, cpu_time_s=20.0)
    store.write(*train_record(resumed), {"steps": 5, "resumed_from_step": 4},
                seed=resumed.seed, wall_time_s=2.0, cpu_time_s=2.0)
    cost = run_cost(preset, store)
    kitchen = cost["by_kind"]["icrt kitchen state"]
    assert kitchen["cells"] == 2 and kitchen["resumed_cells"] == 1
    group = cost["projection"]["groups"]["table-I / icrt kitchen state"]
    assert group["cpu_s_per_cell"] == 20.0  # not (20 + 2) / 2


def test_a_seed_counts_as_finished_once_every_record_its_row_reads_is_there(tmp_path):
    from icil_paper.planning.design import finished_seeds
    from icil_paper.records import features_record

    preset = smoke("tables.icrt_seeds=2")
    store = ResultsStore(preset.name, root=tmp_path)
    units = [u for entry in table_spec(preset, "I").row("icrt+lipvq").entries.values()
             for u in entry.units if u.seed_index == 0]
    measured = [u for u in units if u.features is not None]
    assert measured  # the row's features cell counts too
    for unit in {u.eval.task: u for u in units if u.eval is not None}.values():
        write_eval_record(store, unit, [{"success": True, "steps": 5}], 5.0)
    assert finished_seeds(preset, store)["I", "icrt+lipvq"] == 0  # its features are missing
    store.write(*features_record(measured[0].run, measured[0].features), {}, seed=0,
                wall_time_s=1.0)
    finished = finished_seeds(preset, store)
    assert finished["I", "icrt+lipvq"] == 1 and finished["I", "icrt+mlp"] == 0


def test_the_interim_check_reads_every_row_at_the_seeds_finished_so_far(tmp_path):
    from icil_paper.planning.design import at_seeds, interim_ledger

    preset = smoke()
    assert set(planned_seeds(at_seeds(get_preset("reference"), 3)).values()) == {3}
    store = ResultsStore(preset.name, root=tmp_path)
    assert interim_ledger(preset, store=store) == (0, None)  # nothing finished: no variance
    seeds, ledger = interim_ledger(preset, seeds=2, store=store)
    problems = design_problems(preset, {e.id: e.to_dict() for e in ledger})
    assert seeds == 2 and problems == design_problems(preset, {})  # no records: no power either


def test_the_stage_rule_sends_on_only_rows_of_undecided_claims_a_stage_can_decide():
    from icil_paper.planning.design import stage_plan

    preset = smoke("tables.icrt_seeds=5", "tables.baseline_seeds=5", "tables.seed_stages=5,10,15")
    ledger = [{"id": "I-tokenizer-gap", "sequential": {"next": 10}},   # undecided, decidable
              {"id": "I-lipvq-vs-bc", "sequential": {"next": None}},   # decided
              {"id": "I-lipvq-vs-lfq", "sequential": {"next": None}}]  # stops undecided
    plan = stage_plan(preset, ledger)
    assert plan["continue"]["I", "icrt+mlp"] == (10, ["I-tokenizer-gap"])
    assert plan["continue"]["I", "icrt+lipvq"] == (10, ["I-tokenizer-gap"])
    assert ("I", "bc_transformer") in plan["stop"] and ("I", "icrt+lfq") in plan["stop"]
    # Table IV's MLP row trains Table I's runs: it goes on with them
    seeds, why = plan["continue"]["IV", "icrt+mlp"]
    assert seeds == 10 and why == ["runs of I:icrt+mlp"]
    assert ("IV", "icrt+lip-mlp") in plan["stop"]
    nothing = stage_plan(preset, [])
    assert not nothing["continue"] and nothing["stop"]
    with pytest.raises(ValueError, match="seed_stages.*increasing"):  # OverrideError
        smoke("tables.seed_stages=10,5")


def test_the_reference_preset_has_stages_and_its_ledger_records_each_look(capsys):
    from icil_paper.planning.design import main

    preset = get_preset("reference")
    assert preset.tables.seed_stages == (5, 10, 15)
    ledger = json.loads((ROOT / "results" / "reference" / "claims.json").read_text())["claims"]
    for e in ledger:
        seq, look = e["sequential"], e["look"]
        decided = e["adjusted_verdict"] in ("holds", "does not hold")
        assert decided == look.startswith("decided at look") == (seq["decided_at"] is not None)
        if decided:  # decided at its boundary: the design's p-value is below the level
            assert seq["p_value"] <= 0.05 and seq["decided_at"] in seq["stages"]
        elif e["family"] == "descriptive":  # a rank correlation: described, never tested
            assert look.startswith(f"described at {seq['seeds']} seeds, not tested")
        elif e["verdict"] != "not run":
            assert look.startswith(f"undecided at {seq['seeds'] if seq['seeds'] < 15 else 15}")
    assert main(["--preset", "smoke", "--stages"]) == 2
    assert "seed_stages" in capsys.readouterr().err
    assert main(["--preset", "smoke", "--set", "tables.seed_stages=10,5", "--stages"]) == 2
    assert capsys.readouterr().err.count("\n") == 1  # one line, no traceback


def test_the_stage_prose_and_plan_read_typed_ledger_entries():
    # chapter 0 and `design --stages` pass the ledger as `claims_ledger`/`load_ledger` give
    # it (typed entries), not as the stored dicts
    from icil_paper.planning.design import stage_counts, stage_plan
    from icil_paper.tables.claims import load_ledger

    preset = get_preset("reference")
    ledger = load_ledger(ROOT / "results" / "reference" / "claims.json")
    assert stage_counts([e.to_dict() for e in ledger]) == stage_counts(ledger)
    plan = stage_plan(preset, ledger)
    assert plan == stage_plan(preset, [e.to_dict() for e in ledger])


def test_the_stage_counts_count_decided_going_stopped_and_unlooked_claims():
    from icil_paper.planning.design import stage_counts

    stored = json.loads((ROOT / "results" / "reference" / "claims.json").read_text())["claims"]

    def entry(e, **sequential):
        base = {"decided_at": None, "looks": [], "next": None, "stages": [5, 10, 15],
                "stopped_by": None}  # the stored entry's own stop is not this ledger's
        return {**e, "sequential": {**e["sequential"], **base, **sequential}}

    unlooked = [entry(e) for e in stored]
    n = len(stored)
    assert stage_counts(unlooked)["unlooked"] == n
    looked = {"looks": [{"seeds": 5}], "seeds": 5}
    ledger = [entry(stored[0], decided_at=5, **looked),
              entry(stored[1], next=10, **looked),
              entry(stored[2], stopped_by="budget", **looked),
              entry(stored[3], **looked),
              *unlooked[4:]]
    assert stage_counts(ledger) == {"claims": n, "decided": 1, "decided_at": {5: 1},
                                    "going": [stored[1]["id"]], "stopped": 2, "by_budget": 1,
                                    "unlooked": n - 4}
    all_looked = [*ledger[:4], *(entry(e, **looked) for e in stored[4:])]
    counts = stage_counts(all_looked)
    assert (counts["stopped"], counts["unlooked"]) == (n - 2, 0)


# --------------------------------------------------------------------------- the ledger's design
def test_the_claim_ids_of_the_config_are_the_ledgers():
    from icil_paper.config import CLAIM_IDS
    from icil_paper.paper import claims

    for name in ("smoke", "small", "reference"):
        assert tuple(c.id for c in claims(get_preset(name))) == CLAIM_IDS


def test_the_small_and_reference_presets_carry_the_design():
    from icil_paper.config import (
        CONTINUATION_POWER,
        FAMILY_WEIGHTS,
        PRIMARY_CLAIMS,
        REFERENCE_EPISODES,
    )

    for name in ("small", "reference"):
        t = get_preset(name).tables
        assert (t.primary_claims, t.family_weights, t.continuation_power) == (
            PRIMARY_CLAIMS, FAMILY_WEIGHTS, CONTINUATION_POWER)
    reference = get_preset("reference")
    assert reference.tables.episodes_per_task_by_suite == REFERENCE_EPISODES
    assert 1 <= len(PRIMARY_CLAIMS) <= 6 and sum(FAMILY_WEIGHTS) == 1
    # the Meta-World evaluations of the reference design play its suite's episodes
    unit = table_spec(reference, "I").row("icrt+lipvq").entries["avg"].units[0]
    assert unit.eval.episodes == reference.tables.episodes_by_suite()["metaworld"]


@pytest.mark.parametrize("override,message", [
    ("tables.primary_claims=I-lipvq-vs-bcx", "Did you mean 'I-lipvq-vs-bc'"),
    ("tables.family_weights=0.9,0.2", "summing to 1"),
    ("tables.episodes_per_task_by_suite=kitchen=0", "N >= 1 episodes"),
    ("tables.continuation_power=1.5", "probability below 1"),
])
def test_a_bad_design_stops_with_one_line_before_any_work(override, message):
    from cli_helpers import run_cli
    from icil_paper.config_data import ConfigError

    code, err = run_cli("tables", "--preset", "smoke", "--claims", "--set", override)
    assert code == 2 and message in err and err.count("\n") == 1
    field, value = override.removeprefix("tables.").split("=", 1)
    tables = get_preset("smoke").tables
    bad = tuple(value.split(",")) if field != "continuation_power" else float(value)
    if field == "family_weights":
        bad = tuple(float(x) for x in bad)
    with pytest.raises((ConfigError, ValueError), match=message.split("'")[0]):
        replace(tables, **{field: bad})


def test_the_design_gives_the_families_their_shares_and_leaves_descriptive_claims_out():
    from icil_paper.paper import claims
    from icil_paper.tables.design import (
        DESCRIPTIVE,
        PRIMARY,
        SECONDARY,
        ledger_design,
        older_design,
    )

    preset = get_preset("reference")
    every = claims(preset)
    design = ledger_design(preset, every)
    primary = [c for c, f in design.family.items() if f == PRIMARY]
    assert primary == [c for c in design.family if c in preset.tables.primary_claims]
    assert {c for c, f in design.family.items() if f == DESCRIPTIVE} == {
        "III-smoother-succeeds", "III-smoother-latents-smoother-motion"}
    assert "rank correlation" in design.why["III-smoother-succeeds"]
    assert sum(design.weights[c] for c in primary) == pytest.approx(0.8)
    secondary = [c for c, f in design.family.items() if f == SECONDARY]
    assert sum(design.weights[c] for c in secondary) == pytest.approx(0.2)
    assert design.level("IV-vq") == pytest.approx(0.05 * 0.8 / 6)
    # the level a claim is planned at: its share at the last look's boundary
    assert design.planning_level("IV-vq") < design.level("IV-vq")
    # a primary family that names a rank correlation: it is described, not tested
    odd = preset.with_overrides(["tables.primary_claims=IV-vq,III-smoother-succeeds"])
    assert ledger_design(odd, every).family["III-smoother-succeeds"] == DESCRIPTIVE
    assert ledger_design(odd, every).weights["IV-vq"] == pytest.approx(0.8)
    # no primary family: one family, Holm's equal shares
    holm = ledger_design(preset.replace(tables={"primary_claims": ()}), every)
    tested = [c for c, f in holm.family.items() if f != DESCRIPTIVE]
    assert len(tested) == 22 and all(holm.weights[c] == pytest.approx(1 / 22) for c in tested)
    older = older_design(every, None)
    assert set(older.weights.values()) == {1 / 24} and older.older and not older.sizes


def test_the_committed_reference_run_is_read_at_the_design_it_registered():
    """results/reference/design.json is the design the run registered before its first
    cell: read at it, every claimed row has the seeds of its last look, and the ledger is
    that design's (primary, secondary and descriptive claims). The kitchen run's record,
    kept under older-code/kitchen/, is the older design's and says so."""
    from icil_paper.paper import ledger_design_of
    from icil_paper.tables.claims import read_ledger
    from icil_paper.tables.design import DESCRIPTIVE, PRIMARY, SECONDARY, read_record

    store = ResultsStore("reference", root=ROOT / "results")
    record = read_record(store)
    assert record["design"] == "current" and record["looks"]
    run = as_run(get_preset("reference"), store)
    rows = {f"{t}:{r}": n for (t, r), n in planned_seeds(run).items()}
    last = record["looks"][-1]
    assert not last.get("going_on") or last["seeds"] == max(record["tables"]["seed_stages"])
    assert all(rows[r] == n for r, n in last["rows"].items())
    assert not ledger_design_of(run, store).older
    ledger = read_ledger(ROOT / "results" / "reference" / "claims.json")
    assert {e["family"] for e in ledger["claims"]} <= {PRIMARY, SECONDARY, DESCRIPTIVE}
    kitchen = json.loads((ROOT / "results" / "reference" / "older-code" / "kitchen" /
                          "design.json").read_text())
    assert kitchen["design"] == "older" and kitchen["protocol"] == "kitchen"
    assert "kitchen suite" in kitchen["why"]


def test_a_staged_run_registers_its_design_and_writes_each_look(tmp_path, monkeypatch):
    """`staged_preset(..., write=True)` registers the design before any record, then writes
    each look with every claimed row's seeds; a record of another design is refused."""
    from icil_paper.config_data import ConfigError
    from icil_paper.planning import staged
    from icil_paper.tables.design import read_record, write_record

    preset = smoke("tables.icrt_seeds=2", "tables.baseline_seeds=2", "tables.seed_stages=2,3")
    store = ResultsStore(preset.name, root=tmp_path)
    monkeypatch.setattr(staged, "stage_done", lambda p, s: True)
    monkeypatch.setattr(staged, "claims_ledger", lambda p, s: [
        SimpleNamespace(to_dict=lambda c=c: {"id": c, "sequential": {
            "next": 3 if c == "I-tokenizer-gap" else None}}) for c in claim_rows(p)])
    current, looks = staged.staged_preset(preset, store, write=True)
    record = read_record(store)
    assert record["design"] == "current" and record["tables"]["seed_stages"] == [2, 3]
    assert record["tables"]["primary_claims"] == list(preset.tables.primary_claims)
    assert [look["seeds"] for look in record["looks"]] == [2, 3]
    first = record["looks"][0]
    assert first["going_on"] == {r: 3 for r in first["going_on"]} and "I:icrt+mlp" in first["going_on"]
    assert set(first["rows"].values()) == {2}
    # read back, the same seeds without a look recomputed
    monkeypatch.setattr(staged, "claims_ledger", None)
    assert staged.staged_preset(preset, store) == (current, looks)
    other = preset.with_overrides(["tables.continuation_power=0.2"])
    with pytest.raises(ConfigError, match="registers another design"):
        staged.staged_preset(other, store)
    write_record(store, {**record, "design": "older"})  # an older design's record is read
    assert staged.staged_preset(other, store)[0].tables.continuation_power == 0.1


def test_the_reference_episodes_are_the_cost_optimal_counts_of_its_records():
    from icil_paper.planning.pilot import recorded_episodes, regime_episodes

    episodes = get_preset("reference").tables.episodes_by_suite()
    # Meta-World's from the regime pilot's paired outcomes; ManiSkill's from the committed
    # records of the earlier run (tools.pilot episodes, at the commit its record names)
    assert episodes["metaworld"] == regime_episodes()["episodes"] > 1
    recorded = recorded_episodes()
    assert "maniskill" in recorded
    for suite, n in recorded.items():
        if suite != "kitchen":
            assert n == episodes[suite], suite
    rows = json.loads((ROOT / "results" / "bench" / "episodes.json").read_text())["rows"]
    assert all(0 < r["episode_share"] < 1 and r["seed_by_row_part"] > 0 for r in rows)


def test_a_questions_answer_asks_for_seeds_only_where_the_run_has_fewer():
    """Q1-Q3 as the introduction quotes them: "about N seeds a row would decide it" only when
    the run has fewer than N seeds; where it has them, its effect is not the paper's."""
    from icil_paper.book.report import QUESTIONS, question_answers

    def entry(claim_id, needed, seeds):
        return SimpleNamespace(id=claim_id, table="I", ours=0.01, paper=0.05, size=None,
                               adjusted_verdict="inconclusive", verdict="inconclusive",
                               seeds_needed=needed, seeds={"a": seeds, "b": seeds})

    ledger = [entry(q.decides[0], 12, 5) for q in QUESTIONS]
    assert question_answers(ledger)["Q1"]["outcome"].endswith("about 12 seeds a row would decide it")
    ledger = [entry(q.decides[0], 4, 5) for q in QUESTIONS]
    assert question_answers(ledger)["Q1"]["outcome"] == "undecided"
