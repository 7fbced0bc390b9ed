"""`tools/reference_run.py`: sync copies finished records only, and only what changed; finish
waits for the whole run and keeps the kitchen run's files, labelled."""

from __future__ import annotations

import json
import os

import pytest

from tools.reference_run import (
    KITCHEN,
    _running,
    archive_kitchen,
    copy_finished,
    finished_files,
    start,
    unfinished,
)


def _store(tmp_path):
    store = tmp_path / "store"
    (store / "eval").mkdir(parents=True)
    (store / "eval" / "a__1.json").write_text("{}")
    (store / "eval" / ".a__2.json.tmp").write_text("half")     # a write in progress
    (store / "eval" / "a__3.json.lock").write_text("")         # a lock
    (store / "showcase").mkdir()
    (store / "showcase" / "task.rrd").write_bytes(b"rrd")       # git ignores recordings
    (store / "design.json").write_text('{"looks": []}')
    return store


def test_sync_copies_finished_records_and_nothing_else(tmp_path):
    store = _store(tmp_path)
    assert [str(p) for p in finished_files(store)] == ["design.json", "eval/a__1.json"]
    target = tmp_path / "committed"
    assert copy_finished(store, target) == 2
    assert sorted(str(p.relative_to(target)) for p in target.rglob("*") if p.is_file()) == [
        "design.json", "eval/a__1.json"]


def test_sync_copies_again_only_what_changed(tmp_path):
    store, target = _store(tmp_path), tmp_path / "committed"
    copy_finished(store, target)
    assert copy_finished(store, target) == 0
    (store / "design.json").write_text('{"looks": [{"seeds": 5}]}')   # a look was taken
    assert copy_finished(store, target) == 1
    assert (target / "design.json").read_text() == '{"looks": [{"seeds": 5}]}'


def test_start_refuses_a_second_run_while_one_runs(tmp_path):
    folders = tmp_path / "files"
    folders.mkdir()
    (folders / "reference-run.pid").write_text(str(os.getpid()))   # a live process
    with pytest.raises(SystemExit, match="already running"):
        start("HEAD", tmp_path / "worktree", folders)
    (folders / "reference-run.pid").write_text("999999999")          # no such process
    assert _running(folders) is None


def _cost(tmp_path, finished, planned, looks, stages=(5, 10, 15)):
    path = tmp_path / "cost.json"
    path.write_text(json.dumps({
        "planned_cells": planned, "finished_cells": finished, "projection": {},
        "sittings": [{"elapsed_s": 3600.0, "commits": ["49b6dde"]}],
        "stages": {"stages": list(stages), "looks": looks}}))
    return path


def test_finish_waits_for_every_cell_and_the_last_look(tmp_path):
    assert "3 of its 4 planned cells" in unfinished(_cost(tmp_path, 3, 4, []))
    going = [{"seeds": 5, "going_on": ["I:icrt+lipvq"]}]
    assert "another stage" in unfinished(_cost(tmp_path, 4, 4, going))
    stopped = [{"seeds": 5, "going_on": ["I:icrt+lipvq"]}, {"seeds": 10, "going_on": []}]
    assert unfinished(_cost(tmp_path, 4, 4, stopped)) is None
    assert unfinished(_cost(tmp_path, 4, 4, [{"seeds": s, "going_on": ["x"]} for s in (5, 10, 15)])) is None


def test_the_kitchen_run_is_kept_labelled_and_only_once(tmp_path):
    reference = tmp_path / "reference"
    reference.mkdir()
    (reference / "claims.json").write_text(json.dumps({"claims": [{"id": "I-lipvq-best"}]}))
    (reference / "cost.json").write_text("{}")
    (reference / "design.json").write_text(json.dumps({"protocol": "kitchen", "looks": []}))
    moved = archive_kitchen(reference, "e5c58be")
    assert moved == [f"{KITCHEN}/{name}" for name in ("claims.json", "cost.json", "design.json")]
    assert not any((reference / name).exists() for name in ("claims.json", "cost.json", "design.json"))
    kept = json.loads((reference / KITCHEN / "claims.json").read_text())
    assert kept["made_by"]["commit"] == "e5c58be" and kept["claims"] == [{"id": "I-lipvq-best"}]
    (reference / "design.json").write_text(json.dumps({"looks": []}))   # the new run's
    assert archive_kitchen(reference, "e5c58be") == []
