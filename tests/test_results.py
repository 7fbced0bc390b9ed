import json
import os
import warnings

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

    from icil_paper.bench import save_benchmark

    path = save_benchmark("probe", {"rate": 1.5}, tmp_path / "probe.json")
    record = json.loads(path.read_text())
    assert record["benchmark"] == "probe" and record["rate"] == 1.5
    assert {"git", "packages", "host", "load_average_1min"} <= set(record)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind
