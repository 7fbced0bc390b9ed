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
                              stderr=subprocess.PIPE, text=True) for n in (24, 30)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    alone = {**os.environ, "ICIL_DATA": str(tmp_path / "alone")}
    done = subprocess.run(_demos_cmd(30), env=alone, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    (path,) = (tmp_path / "both").rglob("generated.hdf5")
    (single,) = (tmp_path / "alone").rglob("generated.hdf5")
    both, one = load_demos(path), load_demos(single)
    assert [d.name for d in both] == [d.name for d in one] == [f"demo_{i}" for i in range(30)]
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
