"""`icil-paper plan`: the seeds, cells and CPU-hours that would decide each undecided claim,
and the override that runs exactly those cells."""

from __future__ import annotations

import json

import pytest

from cli_helpers import run_cli
from icil_paper.config import get_preset
from icil_paper.paper import TABLES, table_spec
from icil_paper.planning.decide import make_plan, seeds_entry_name
from icil_paper.planning.design import planned_seeds
from icil_paper.tables.cells import plan

LEDGER = [
    {"id": "I-lipvq-vs-bc", "table": "I", "verdict": "holds", "seeds_needed": 40},
    {"id": "I-lipvq-vs-lfq", "table": "I", "verdict": "inconclusive", "seeds_needed": 3},
    {"id": "fig5-best", "table": "fig5", "verdict": "holds", "adjusted_verdict":
     "inconclusive", "seeds_needed": 2},
    {"id": "III-smoother-succeeds", "table": "III", "verdict": "inconclusive",
     "seeds_needed": None, "power_note": "not planned: no closed form"},
]
# per kind: 2 cells, 10 evaluation records; 100 CPU s of training a cell, 5 an evaluation
COST = {"by_kind": {kind: {"cells": 2, "records": 12, "cpu_s": 250.0, "train_cpu_s": 200.0}
                    for kind in ("icrt kitchen state", "bc_transformer kitchen state",
                                 "act kitchen state", "mcr kitchen rgb", "act maniskill state",
                                 "bc_transformer maniskill state", "mcr maniskill rgbd")}}


def test_row_names_follow_the_row_seeds_setting():
    assert seeds_entry_name("IV", "icrt+lip-mlp") == "I:icrt+lip-mlp"  # Table I's runs
    assert seeds_entry_name("fig5", "2^9 (the paper's 2^11)") == "fig5:512"
    assert seeds_entry_name("II", "act+lipvq") == "II:act+lipvq"


def test_the_plan_raises_the_rows_of_undecided_claims_and_prices_their_cells(tmp_path):
    preset = get_preset("smoke")
    result = make_plan(preset, LEDGER, COST, cores=4)
    by_id = {c["id"]: c for c in result["claims"]}
    assert set(by_id) == {"I-lipvq-vs-lfq", "fig5-best", "III-smoother-succeeds"}
    assert not by_id["III-smoother-succeeds"]["planned"]
    assert "no closed form" in by_id["III-smoother-succeeds"]["why_not"]

    bigger = preset.with_overrides([result["set"]])  # the override the plan prints
    seeds = planned_seeds(bigger)
    assert seeds["I", "icrt+lipvq"] == seeds["I", "icrt+lfq"] == seeds["III", "icrt+lipvq"] == 3
    assert seeds["I", "bc_transformer"] == 1  # a decided claim's rows keep their seeds
    assert all(seeds["fig5", row.label] >= 2 for row in table_spec(bigger, "fig5").rows)

    lfq = by_id["I-lipvq-vs-lfq"]  # alone: its 2 rows x 3 seeds, none stored yet
    assert lfq["seeds_now"] == 1 and lfq["cells"] == 6
    evals = len(preset.data.robocasa_tasks)  # at least Table I's evaluations a cell
    assert lfq["cpu_hours"] >= round(6 * (100 + 5 * evals) / 3600, 2)
    # the total is every cell the override's run computes (an empty store: all of them)
    assert result["total"]["cells"] == len(plan([table_spec(bigger, t) for t in TABLES]))
    assert result["total"]["wall_hours"] == pytest.approx(
        result["total"]["cpu_hours"] / 4, abs=0.01)


def test_plan_command_writes_the_plan_and_refuses_missing_inputs(tmp_path, monkeypatch):
    folder = tmp_path / "results" / "smoke"
    code, err = run_cli("plan", "--preset", "smoke")
    assert code == 2 and "claims.json is missing" in err and len(err.splitlines()) == 1
    folder.mkdir(parents=True)
    (folder / "claims.json").write_text(json.dumps({"claims": LEDGER}))
    (folder / "cost.json").write_text(json.dumps(COST))
    code, err = run_cli("plan", "--preset", "smoke", "--cores", "0")
    assert code == 2 and "--cores" in err
    code, err = run_cli("plan", "--preset", "smoke", "--cores", "8", "--max-seeds", "2")
    assert code == 0, err
    written = json.loads((folder / "plan.json").read_text())
    assert written["cores"] == 8
    lfq = next(c for c in written["claims"] if c["id"] == "I-lipvq-vs-lfq")
    assert not lfq["planned"] and "--max-seeds 2" in lfq["why_not"]


def test_a_staged_run_is_planned_from_the_seeds_it_reached(tmp_path):
    """With seeds in stages and no look yet, every claimed row has the first stage's seeds,
    not the preset's fixed ones: the plan starts from those."""
    folder = tmp_path / "results" / "smoke"
    folder.mkdir(parents=True)
    (folder / "claims.json").write_text(json.dumps({"claims": LEDGER}))
    (folder / "cost.json").write_text(json.dumps(COST))
    fixed = min(n for (t, _), n in planned_seeds(get_preset("smoke")).items() if t == "I")
    code, err = run_cli("plan", "--preset", "smoke", "--set", "tables.seed_stages=2,4")
    assert code == 0, err
    written = json.loads((folder / "plan.json").read_text())
    lfq = next(c for c in written["claims"] if c["id"] == "I-lipvq-vs-lfq")
    assert fixed != 2 and lfq["seeds_now"] == 2
