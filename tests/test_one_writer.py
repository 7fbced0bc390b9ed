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
