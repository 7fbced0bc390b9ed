"""One writer per data set, one source for the data folder, evaluation that trusts a policy
only with its record, and the planning commands' files read through one loader."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from icil_paper.data import load_demos

ICIL = [sys.executable, "-m", "icil_paper.cli"]
TASK = "synthetic/task0"


def _demos_cmd(n: int) -> list[str]:
    return [*ICIL, "demos", "--preset", "smoke", "--task", TASK, "--n", str(n), "--workers", "1",
            "--no-progress"]


def test_two_concurrent_demos_runs_of_one_data_set_lose_nothing(tmp_path):
    """Two `icil-paper demos` of one data set at once (as in `--n 2` and `--n 3`): both exit
    0, and the data set holds every demonstration, each equal to a single run's."""
    env = {**os.environ, "ICIL_DATA": str(tmp_path / "both")}
    procs = [subprocess.Popen(_demos_cmd(n), env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for n in (160, 240)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    alone = {**os.environ, "ICIL_DATA": str(tmp_path / "alone")}
    done = subprocess.run(_demos_cmd(240), env=alone, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    (path,) = (tmp_path / "both").rglob("generated.hdf5")
    (single,) = (tmp_path / "alone").rglob("generated.hdf5")
    both, one = load_demos(path), load_demos(single)
    assert [d.name for d in both] == [d.name for d in one] == [f"demo_{i}" for i in range(240)]
    for a, b in zip(both, one, strict=True):
        assert a.seed == b.seed and np.array_equal(a.actions, b.actions), a.name
        assert all(np.array_equal(a.obs[k], b.obs[k]) for k in b.obs), a.name
    assert not list(path.parent.glob(".*.lock")) and not list(path.parent.glob("*.parts"))


def test_the_data_folder_is_the_specs_not_the_environments(tmp_path, monkeypatch):
    """`ICIL_DATA=A icil-paper train ... --set data.root=B`: the data set is generated
    under B only (the command carries its preset down, never re-reading $ICIL_DATA)."""
    from cli_helpers import run_cli

    a, b = tmp_path / "A", tmp_path / "B"
    monkeypatch.setenv("ICIL_DATA", str(a))
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "runs"))
    code, err = run_cli("train", "--preset", "smoke", "--tasks", "kitchen/open_drawer",
                        "--tokenizer", "mlp", "--set", f"data.root={b}",
                        "--set", "data.demos_per_task=1", "--steps", "2", "--quiet")
    assert code == 0, err
    assert not a.exists(), "nothing under $ICIL_DATA when data.root says otherwise"
    assert len(load_demos(b / "smoke" / "kitchen" / "open_drawer" / "generated.hdf5")) == 1


def test_only_the_preset_reads_the_data_folder_from_the_environment():
    """$ICIL_DATA is folded into the preset where presets are made (`config.get_preset`,
    which the command line calls once); no other module reads it."""
    from pathlib import Path

    import icil_paper

    src = Path(icil_paper.__file__).parent
    readers = sorted(str(p.relative_to(src)) for p in src.rglob("*.py")
                     for line in p.read_text().splitlines()
                     if ("environ" in line or "getenv" in line)
                     and ("ICIL_DATA" in line or "DATA_ENV_VAR" in line))
    assert readers == ["config.py"], readers


def _kitchen_dataset(path):
    """A small robomimic-layout file of kitchen/open_drawer's widths (7-D actions, 27-D state)."""
    import h5py

    rng = np.random.default_rng(0)
    with h5py.File(path, "w") as f:
        f.create_group("data").attrs["task"] = "kitchen/open_drawer"
        for i in range(2):
            g = f.create_group(f"data/demo_{i}")
            g.attrs["num_samples"] = 12
            g["actions"] = rng.uniform(-1, 1, (12, 7)).astype(np.float32)
            g["obs/proprio"] = rng.normal(size=(12, 9)).astype(np.float32)
            g["obs/object"] = rng.normal(size=(12, 18)).astype(np.float32)
    return path


def test_eval_never_stores_another_runs_policy_under_a_runs_key(tmp_path, monkeypatch):
    """A 3-step run's policy.pt copied over a 4-step run's, then `eval --run-dir` on the
    4-step run: the foreign file is set aside (kept) and the 4-step run's own policy is
    restored from its checkpoints before anything is rolled out or stored."""
    import shutil
    import warnings

    from cli_helpers import run_cli
    from icil_paper.fileio import file_sha256
    from icil_paper.results import ResultsStore
    from icil_paper.train import POLICY_FILE, load_policy

    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "runs"))
    data = _kitchen_dataset(tmp_path / "drawer.hdf5")
    runs = {}
    for steps in (3, 4):
        runs[steps] = tmp_path / f"run{steps}"
        code, err = run_cli("train", "--preset", "smoke", "--policy", "act", "--dataset",
                            str(data), "--steps", str(steps), "--run-dir", str(runs[steps]),
                            "--quiet")
        assert code == 0, err
    own = file_sha256(runs[4] / POLICY_FILE)
    shutil.copyfile(runs[3] / POLICY_FILE, runs[4] / POLICY_FILE)
    # a run folder that cannot be written: nothing can be set aside, so one line naming it
    from test_reliability import _run_with_read_only, one_line_error

    out = _run_with_read_only(runs[4], [*ICIL, "eval", "--preset", "smoke", "--run-dir",
                                        str(runs[4]), "--episodes", "1", "--max-steps", "3",
                                        "--quiet"], dict(os.environ))
    one_line_error(out.returncode, out.stderr, str(runs[4] / POLICY_FILE),
                   "is not this run's trained policy")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, err = run_cli("eval", "--preset", "smoke", "--run-dir", str(runs[4]),
                            "--episodes", "1", "--max-steps", "3", "--quiet")
    assert code == 0, err
    assert file_sha256(runs[4] / POLICY_FILE) == own, "the 4-step run's own policy is back"
    assert load_policy(runs[4]).meta["steps"] == 4
    (aside,) = runs[4].glob(f"{POLICY_FILE}.corrupt-*")
    assert file_sha256(aside) == file_sha256(runs[3] / POLICY_FILE), "set aside, not deleted"
    assert any("trained for the run of key" in str(w.message) for w in caught)
    (record,) = ResultsStore("smoke").records("eval")
    assert record["config"]["run"]["train"]["steps"] == 4


def test_a_record_with_fields_of_the_wrong_type_is_recomputed(tmp_path, monkeypatch):
    """A train record whose `files` is a string (not a map): set aside as corrupt and the
    run's record computed again, not an AttributeError."""
    import json
    import warnings

    from cli_helpers import run_cli
    from icil_paper.results import CorruptRecordWarning, ResultsStore

    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "runs"))
    data = _kitchen_dataset(tmp_path / "drawer.hdf5")
    args = ["train", "--preset", "smoke", "--policy", "act", "--dataset", str(data),
            "--steps", "2", "--quiet"]
    assert run_cli(*args)[0] == 0
    (path,) = ResultsStore("smoke").dir.glob("train/*.json")
    record = json.loads(path.read_text())
    path.write_text(json.dumps({**record, "files": "policy.pt"}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, err = run_cli(*args)
    assert code == 0, err
    assert any(w.category is CorruptRecordWarning and "'files' is a string" in str(w.message)
               for w in caught), [str(w.message) for w in caught]
    assert isinstance(json.loads(path.read_text())["files"], dict)


def test_the_planning_commands_name_a_damaged_file_in_one_line(tmp_path):
    """`python -m icil_paper.planning.design --interim` on a truncated claims.json and
    `python -m icil_paper.planning.cost` with a truncated train record: exit 2, one line
    naming the file and the fix (no JSONDecodeError traceback)."""
    store = tmp_path / "results" / "smoke"
    (store / "train").mkdir(parents=True)
    env = {**os.environ, "ICIL_RESULTS": str(tmp_path / "results")}
    claims = store / "claims.json"
    claims.write_text('{"claims": [{"id": "x", "verd')
    cmd = [sys.executable, "-m", "icil_paper.planning.design", "--preset", "smoke", "--interim"]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr
    assert str(claims) in done.stderr and "icil-paper reproduce" in done.stderr
    claims.unlink()
    record = store / "train" / "icrt__x__generated__seed0__0123456789abcdef.json"
    record.write_text('{"schema": 1, "kind": "train", "wall_')
    cmd = [sys.executable, "-m", "icil_paper.planning.cost", "--preset", "smoke"]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr
    assert str(record) in done.stderr and "move it out of the results folder" in done.stderr
    assert not (store / "cost.json").exists()


def test_the_cost_loader_names_a_field_of_the_wrong_type(tmp_path):
    import pytest

    from icil_paper.fileio import UnreadableFileError
    from icil_paper.planning.cost import read_cost

    path = tmp_path / "cost.json"
    path.write_text('{"preset": "smoke", "total": "3 hours"}')
    with pytest.raises(UnreadableFileError, match=r"cost.json is not .*'total' is a string, "
                                                  r"not an object.*planning.cost"):
        read_cost(path)


def test_write_protected_output_folders_are_refused_up_front(tmp_path):
    """`icil-paper demos` into a read-only data folder and `icil-paper export-tokenizer`
    into a read-only OUT: one line naming the folder, exit 2, nothing generated."""
    from icil_paper.config import get_preset
    from icil_paper.runspec import run_spec
    from icil_paper.sim.synthetic import synthetic_demos
    from icil_paper.train import train_policy
    from test_reliability import _run_with_read_only, one_line_error

    locked = tmp_path / "locked"
    locked.mkdir()
    env = {**os.environ, "ICIL_DATA": str(locked / "data")}
    out = _run_with_read_only(locked, [*ICIL, "demos", "--preset", "smoke", "--task", TASK,
                                       "--n", "2", "--no-progress"], env)
    one_line_error(out.returncode, out.stderr, "cannot write to data.root=", "data.root")
    assert not (locked / "data").exists()
    run = run_spec(get_preset("smoke").with_overrides(["train.steps=2"]), "icrt", "mlp",
                   tasks=["synthetic/task0"])
    train_policy(run, run_dir=tmp_path / "run", progress=False,
                 demos=synthetic_demos(n_tasks=1, per_task=2, steps=(10, 12), seed=0))
    out = _run_with_read_only(locked, [*ICIL, "export-tokenizer", str(tmp_path / "run"),
                                       str(locked / "out")], env)
    one_line_error(out.returncode, out.stderr, f"cannot write to OUT {locked / 'out'}")
    assert not (locked / "out").exists()
