"""`tools/reference_run.py`'s sync copies finished records only, and only what changed."""

from __future__ import annotations

import os

import pytest

from tools.reference_run import _running, copy_finished, finished_files, start


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
