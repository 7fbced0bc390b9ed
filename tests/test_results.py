import json
import os
import time
import warnings

import numpy as np
import pytest

from icil_paper.results import (
    CorruptRecordWarning,
    ResultsStore,
    atomic_write_json,
    config_hash,
)

CONFIG = {"tokenizer": "lipvq", "steps": 3, "seed": 1}


def test_run_writes_a_record_with_provenance(tmp_path):
    store = ResultsStore("smoke", root=tmp_path)
    record = store.run("tokenizer", "lipvq", CONFIG, lambda: {"recon_mse": 0.5}, seed=1)
    assert record["metrics"] == {"recon_mse": 0.5}
    assert record["config"] == CONFIG and record["config_hash"] == config_hash(CONFIG)
    assert record["seed"] == 1 and record["preset"] == "smoke"
    assert record["packages"]["torch"] and record["host"]["cpu_count"] >= 1
    assert "git_commit" in record and record["wall_time_s"] >= 0
    path = store.path_for("tokenizer", "lipvq", config_hash(CONFIG))
    assert path.parent == tmp_path / "smoke" / "tokenizer"
    assert not list(path.parent.glob("*.tmp")), "temporary files must not be left behind"


def test_a_record_carries_the_cpu_time_of_its_computation(tmp_path):
    def busy():
        deadline = time.process_time() + 0.2
        while time.process_time() < deadline:
            pass
        return {"x": 1.0}

    record = ResultsStore("smoke", root=tmp_path).run("tokenizer", "busy", CONFIG, busy)
    assert 0.15 <= record["cpu_time_s"] <= record["wall_time_s"] + 0.05


def test_existing_result_is_skipped_unless_forced(tmp_path):
    store = ResultsStore("smoke", root=tmp_path)
    calls = []

    def compute():
        calls.append(1)
        return {"value": len(calls)}

    assert store.run("k", "n", CONFIG, compute)["metrics"]["value"] == 1
    assert store.run("k", "n", CONFIG, compute)["metrics"]["value"] == 1
    assert len(calls) == 1
    assert store.run("k", "n", CONFIG, compute, force=True)["metrics"]["value"] == 2
    other = {**CONFIG, "steps": 4}
    assert store.run("k", "n", other, compute)["metrics"]["value"] == 3


def test_failed_run_never_overwrites_a_good_result(tmp_path):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("k", "n", CONFIG, lambda: {"value": 1})

    def boom():
        raise RuntimeError("diverged")

    with pytest.raises(RuntimeError, match="diverged"):
        store.run("k", "n", CONFIG, boom, force=True)
    assert store.get("k", "n", CONFIG)["metrics"]["value"] == 1
    with pytest.raises(ValueError, match="non-finite"):
        store.run("k", "n", CONFIG, lambda: {"value": float("nan")}, force=True)
    assert store.get("k", "n", CONFIG)["metrics"]["value"] == 1


@pytest.mark.parametrize("damage", ["truncate", "drop_key", "edit_config", "not_object"])
def test_corrupt_record_is_reported_set_aside_and_recomputed(tmp_path, damage):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("k", "n", CONFIG, lambda: {"value": 1})
    path = store.path_for("k", "n", config_hash(CONFIG))
    record = json.loads(path.read_text())
    if damage == "truncate":
        path.write_text(path.read_text()[:40])
    elif damage == "drop_key":
        del record["metrics"]
        path.write_text(json.dumps(record))
    elif damage == "edit_config":
        record["config"]["steps"] = 999
        path.write_text(json.dumps(record))
    else:
        path.write_text("[1, 2]")
    with pytest.warns(CorruptRecordWarning, match="corrupt result"):
        fresh = store.run("k", "n", CONFIG, lambda: {"value": 2})
    assert fresh["metrics"]["value"] == 2
    assert list(path.parent.glob("*.corrupt-*")), "the corrupt file is kept for inspection"


def test_table_lists_records_and_skips_corrupt_ones(tmp_path):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("tokenizer", "vq", {"n": 1}, lambda: {"smooth": 1.0})
    store.run("tokenizer", "lipvq", {"n": 2}, lambda: {"smooth": 0.5})
    store.run("eval", "icrt", {"n": 3}, lambda: {"success": 0.2})
    (tmp_path / "smoke" / "eval" / "junk__0.json").write_text("{")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = store.table()
    assert any(issubclass(w.category, CorruptRecordWarning) for w in caught)
    assert sorted(table["name"]) == ["icrt", "lipvq", "vq"]
    assert set(store.table("tokenizer")["smooth"]) == {1.0, 0.5}


def test_atomic_write_leaves_old_file_when_serialization_fails(tmp_path):
    path = tmp_path / "r.json"
    atomic_write_json(path, {"ok": 1})
    with pytest.raises(TypeError):
        atomic_write_json(path, {"bad": object()})
    assert json.loads(path.read_text()) == {"ok": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_results_root_follows_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "elsewhere"))
    store = ResultsStore("small")
    store.run("k", "n", CONFIG, lambda: {"v": 1})
    assert os.path.exists(tmp_path / "elsewhere" / "small" / "k")


def test_benchmark_records_carry_provenance(tmp_path):
    import json

    from icil_paper.results import save_benchmark

    path = save_benchmark("probe", {"rate": 1.5}, tmp_path / "probe.json")
    record = json.loads(path.read_text())
    assert record["benchmark"] == "probe" and record["rate"] == 1.5
    assert {"git", "packages", "host", "load_average_1min"} <= set(record)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


# ---------------------------------------------------------------- reliability (issue 13)

def _corrupt(path):
    path.write_text(path.read_text()[:40])


def test_corruptions_within_one_second_are_all_kept(tmp_path, monkeypatch):
    import datetime as dt

    from icil_paper import results

    class Frozen(dt.datetime):
        @classmethod
        def now(cls, tz=None):
            return dt.datetime(2025, 1, 2, 3, 4, 5, 678, tzinfo=tz)

    monkeypatch.setattr(results, "datetime", Frozen)
    store = ResultsStore("smoke", root=tmp_path)
    path = store.path_for("k", "n", config_hash(CONFIG))
    damaged = []
    for value in (1, 2, 3):
        store.run("k", "n", CONFIG, lambda v=value: {"value": v}, force=True)
        _corrupt(path)
        damaged.append(path.read_text())
        with pytest.warns(CorruptRecordWarning):
            assert store.get("k", "n", CONFIG) is None
    kept = sorted(path.parent.glob("*.corrupt-*"))
    assert len(kept) == 3, [p.name for p in kept]
    assert sorted(p.read_text() for p in kept) == sorted(damaged)


def _racing_read(monkeypatch, before=None, after=None):
    """Run `before(path)` / `after(path)` around every record read, as another process might."""
    from icil_paper import results

    real = results._read_record

    def read(path, *args, **kwargs):
        if before:
            before(path)
        out = real(path, *args, **kwargs)
        if after:
            after(path)
        return out

    monkeypatch.setattr(results, "_read_record", read)


def _other_process_sets_aside(path):
    if path.exists():
        os.replace(path, path.with_name(path.name + ".corrupt-by-other"))


@pytest.mark.parametrize("when", ["after", "before"])
def test_losing_the_race_to_set_aside_a_corrupt_record_is_harmless(tmp_path, monkeypatch, when):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("k", "n", CONFIG, lambda: {"value": 1})
    path = store.path_for("k", "n", config_hash(CONFIG))
    _corrupt(path)
    damaged = path.read_text()
    _racing_read(monkeypatch, **{when: _other_process_sets_aside})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the winner reported it; the loser stays quiet
        assert store.get("k", "n", CONFIG) is None
    assert not path.exists()
    [kept] = path.parent.glob("*.corrupt-*")
    assert kept.read_text() == damaged
    # records() lists the folder first, then reads: the same race there.
    store.run("k", "n", CONFIG, lambda: {"value": 2})
    _corrupt(path)
    assert store.records("k") == []


def test_a_fresh_record_written_meanwhile_is_not_set_aside(tmp_path, monkeypatch):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("k", "n", CONFIG, lambda: {"value": 1})
    path = store.path_for("k", "n", config_hash(CONFIG))
    _corrupt(path)
    other = ResultsStore("smoke", root=tmp_path)

    def other_process_recomputes(p):
        _other_process_sets_aside(p)
        other.write("k", "n", CONFIG, {"value": 2}, seed=0, wall_time_s=0.0)

    _racing_read(monkeypatch, after=other_process_recomputes)
    store.get("k", "n", CONFIG)
    monkeypatch.undo()
    assert store.get("k", "n", CONFIG)["metrics"]["value"] == 2


def test_threads_reading_one_corrupt_record_never_crash(tmp_path):
    import threading

    store = ResultsStore("smoke", root=tmp_path)
    path = store.path_for("k", "n", config_hash(CONFIG))
    errors = []

    def read(barrier):
        barrier.wait()
        try:
            assert store.get("k", "n", CONFIG) is None
        except BaseException as exc:  # collected and reported below
            errors.append(exc)

    for _ in range(10):
        store.run("k", "n", CONFIG, lambda: {"value": 1}, force=True)
        _corrupt(path)
        barrier = threading.Barrier(6)
        threads = [threading.Thread(target=read, args=(barrier,)) for _ in range(6)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CorruptRecordWarning)
            for t in threads:
                t.start()
            for t in threads:
                t.join()
    assert not errors, errors
    assert len(list(path.parent.glob("*.corrupt-*"))) == 10
    assert not list(path.parent.glob(".*.tmp"))


@pytest.mark.parametrize("bad", [
    {"value": float("nan")},
    {"per_task": [0.5, float("inf")]},
    {"nested": {"success": [{"rate": float("-inf")}]}},
])
def test_a_stored_non_finite_metric_is_a_corrupt_record(tmp_path, bad):
    store = ResultsStore("smoke", root=tmp_path)
    store.run("k", "n", CONFIG, lambda: {"value": 1})
    path = store.path_for("k", "n", config_hash(CONFIG))
    record = json.loads(path.read_text())
    record["metrics"] = bad
    path.write_text(json.dumps(record))  # json writes NaN and Infinity; the store refuses them
    with pytest.warns(CorruptRecordWarning, match="metric .* is (nan|inf|-inf)"):
        assert store.get("k", "n", CONFIG) is None
    assert list(path.parent.glob("*.corrupt-*"))


@pytest.mark.parametrize("bad,where", [
    ({"per_task": [0.5, float("nan")]}, r"'per_task'\[1\]"),
    ({"by_task": {"drawer": {"rate": float("inf")}}}, r"'by_task'\['drawer'\]\['rate'\]"),
    ({"rates": np.array([0.1, float("nan")])}, r"'rates'\[1\]"),
    ({"rate": np.float32("nan")}, "'rate'"),
])
def test_write_refuses_nested_non_finite_metrics(tmp_path, bad, where):
    store = ResultsStore("smoke", root=tmp_path)
    with pytest.raises(ValueError, match=f"metric {where} is .*non-finite"):
        store.write("k", "n", CONFIG, bad, seed=0, wall_time_s=0.0)
    assert not (tmp_path / "smoke").exists()
    store.write("k", "n", CONFIG, {"ok": [1, 2.5, {"x": None}], "flag": True}, 0, 0.0)


@pytest.mark.parametrize("value", ["", "  "])
def test_empty_results_variable_counts_as_unset(monkeypatch, value):
    from icil_paper.results import results_root
    from icil_paper.setup.provenance import REPO_ROOT

    monkeypatch.setenv("ICIL_RESULTS", value)
    assert results_root() == REPO_ROOT / "results"
    assert ResultsStore("small").dir == REPO_ROOT / "results" / "small"


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077])
def test_atomic_writes_get_the_usual_file_mode(tmp_path, umask):
    import stat

    from icil_paper.fileio import atomic_write_bytes

    old = os.umask(umask)
    try:
        path = tmp_path / "r.bin"
        atomic_write_bytes(path, b"data")
        atomic_write_json(tmp_path / "r.json", {"a": 1})
        atomic_write_bytes(path, b"again")  # replacing keeps the usual mode too
    finally:
        os.umask(old)
    for p in (path, tmp_path / "r.json"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~umask, oct(p.stat().st_mode)
    assert path.read_bytes() == b"again"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.bin", "r.json"]


def test_a_record_written_into_results_does_not_make_the_code_dirty(tmp_path, monkeypatch):
    import subprocess

    from icil_paper.setup import provenance

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "r.json").write_text("{}")
    (tmp_path / "code.py").write_text("x = 1\n")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "init")
    monkeypatch.setattr(provenance, "REPO_ROOT", tmp_path)

    def dirty():
        provenance.git_state.cache_clear()
        return provenance.git_state()["dirty"]

    assert dirty() is False
    (tmp_path / "results" / "r.json").write_text('{"a": 1}')
    assert dirty() is False
    (tmp_path / "code.py").write_text("x = 2\n")
    assert dirty() is True
    provenance.git_state.cache_clear()
