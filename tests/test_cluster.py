"""`reproduce --executor ray` on a cluster whose nodes share no files with the driver.

One machine stands in for a cluster: a Ray head with no CPUs (so no cell runs beside the
driver) and two worker nodes, each started in its own mount namespace with an empty tmpfs
over the driver's results, runs and data folders: a node sees the driver's paths but none of
its files, as a node of a cluster without shared storage does. Node A also declares a GPU
(`--num-gpus 1`; cells fall back to CPU torch there). Checked, against the records the serial
executor writes for the same stages:

- `--gpus-per-cell 1`: every cell runs on node A, and every record comes back;
- a node killed (its whole process group) while it runs a cell: the run still exits 0, its
  cell runs again on the other node, every record is in the driver's store;
- a second run of both stages computes nothing.

Every process the test starts is ended by its process group id (never `ray stop`, which
would end every Ray on the machine). Needs root and `unshare` (skips with the reason).
"""

from __future__ import annotations

import json
import math
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import icil_paper

pytestmark = [pytest.mark.slow, pytest.mark.ray]  # its cluster is a Ray too

SRC = str(Path(icil_paper.__file__).resolve().parents[1])
RAY = Path(sys.executable).with_name("ray")
SETTINGS = ("--preset", "smoke", "--set", "data.robocasa_tasks=kitchen/open_drawer",
            "--set", "tables.codebook_sizes=16,32")
GPU_STAGE, KILL_STAGE = "table-fig5", "table-IV"
TIMING = re.compile(r"_s$")  # seconds: wall time, steps per second


def _why_not() -> str | None:
    if os.geteuid() != 0:
        return "needs root to give a Ray node its own mount namespace (unshare -m)"
    if shutil.which("unshare") is None:
        return "`unshare` (util-linux) is not installed"
    if not RAY.exists():
        return f"Ray's command is not installed beside {sys.executable}"
    probe = subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs none /mnt"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        return f"this machine refuses mount namespaces: {probe.stderr.strip()}"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """Ray processes started by this test, each in its own session (so its own group)."""

    def __init__(self, root: Path, env: dict[str, str]):
        self.root, self.env, self.groups = root, env, {}
        self.port = _free_port()
        self.address = f"127.0.0.1:{self.port}"

    def start(self, name: str, args: list[str], hide: tuple[Path, ...] = (),
              attempts: int = 3) -> Path:
        """Start one node and wait until it has joined; returns its TMPDIR (where its cells'
        private folders appear). On a busy machine a node's agents can miss Ray's fixed
        start-up waits: a node that has not joined in time is ended and started again."""
        tmp = self.root / name
        tmp.mkdir(parents=True)
        for attempt in range(1, attempts + 1):
            if name == "head":  # a fresh port for each try
                self.port = _free_port()
                self.address = f"127.0.0.1:{self.port}"
                args = [*args, "--port", str(self.port)]
            cmd = [str(RAY), "start", "--block", "--disable-usage-stats",
                   "--object-store-memory", str(100 * 2**20), *args]
            if hide:  # the node's own view: an empty tmpfs over each of the driver's folders
                mounts = " && ".join(f"mount -t tmpfs none {shlex.quote(str(d))}" for d in hide)
                cmd = ["unshare", "-m", "sh", "-c", f'{mounts} && exec "$@"', "sh", *cmd]
            log = tmp / f"node{attempt}.log"
            with open(log, "wb") as sink:
                self.groups[name] = subprocess.Popen(
                    cmd, env={**self.env, "TMPDIR": str(tmp)}, stdout=sink,
                    stderr=subprocess.STDOUT, start_new_session=True)
            end = time.time() + 75  # a node joins in about 25 s on a busy 2-core machine
            while time.time() < end and self.groups[name].poll() is None:
                if "will now block" in log.read_text(errors="replace"):  # joined
                    return tmp
                time.sleep(0.5)
            self.kill(name)
            if name == "head":
                args = args[:-2]
        raise AssertionError(f"Ray node {name} did not start in {attempts} attempts: "
                             + log.read_text(errors="replace")[-2000:])

    def kill(self, name: str) -> None:
        proc = self.groups.pop(name)
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                break
            try:
                proc.wait(timeout=10)
                if sig == signal.SIGTERM:  # the group may outlive its leader
                    time.sleep(0.5)
            except subprocess.TimeoutExpired:
                pass

    def stop(self) -> None:
        for name in reversed(list(self.groups)):
            self.kill(name)


def _reproduce(env: dict[str, str], *args: str, timeout: float = 600) -> str:
    run = subprocess.run([sys.executable, "-m", "icil_paper.cli", "reproduce", *SETTINGS, *args],
                         env=env, capture_output=True, text=True, timeout=timeout)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return run.stdout + run.stderr


def _same(a, b) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        keys = {k for k in a if not TIMING.search(k)} | {k for k in b if not TIMING.search(k)}
        return all(_same(a.get(k), b.get(k)) for k in keys)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):  # motion: ~1e-6 relative
        return math.isclose(a, b, rel_tol=1e-5, abs_tol=1e-9)
    return a == b


def _records(results: Path) -> dict[str, dict]:
    return {p.relative_to(results).as_posix(): json.loads(p.read_text())
            for p in sorted((results / "smoke").glob("*/*.json"))
            if p.parent.name in ("train", "eval", "features")}


def _folders(root: Path) -> dict[str, str]:
    return {"ICIL_RESULTS": str(root / "results"), "ICIL_RUNS": str(root / "runs")}


def test_cells_on_nodes_without_the_drivers_files(tmp_path):
    why = _why_not()
    if why:
        pytest.skip(why)
    base = {k: v for k, v in os.environ.items() if not k.startswith("ICIL_")}
    base.update(PYTHONPATH=os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
                RAY_AUTH_MODE="disabled", RAY_USAGE_STATS_ENABLED="0", MUJOCO_GL="egl",
                RAY_health_check_period_ms="1000", RAY_health_check_failure_threshold="3",
                RAY_health_check_timeout_ms="1000", RAY_raylet_start_wait_time_s="180",
                RAY_agent_register_timeout_ms="300000",  # a busy machine starts agents slowly
                OMP_NUM_THREADS="1")
    data = tmp_path / "data"  # generated by the serial run, read by the driver of the Ray runs
    serial = {**base, **_folders(tmp_path / "serial"), "ICIL_DATA": str(data)}
    _reproduce(serial, "--stages", GPU_STAGE, KILL_STAGE, "--executor", "serial")
    expected = _records(tmp_path / "serial" / "results")
    assert expected and any(k.startswith("smoke/train/") for k in expected)

    driver = tmp_path / "driver"
    env = {**base, **_folders(driver), "ICIL_DATA": str(data)}
    hide = (driver / "results", driver / "runs", data)
    for folder in hide:
        folder.mkdir(parents=True, exist_ok=True)
    cluster = Cluster(Path(f"/tmp/icil-cluster-{os.getpid()}"), base)
    try:
        cluster.start("head", ["--head", "--num-cpus", "0", "--num-gpus", "0",
                               "--include-dashboard", "false",
                               "--dashboard-port", str(_free_port())])
        tmp_a = cluster.start("a", ["--address", cluster.address, "--num-cpus", "1",
                                    "--num-gpus", "1"], hide)
        tmp_b = cluster.start("b", ["--address", cluster.address, "--num-cpus", "1"], hide)

        # --gpus-per-cell 1: only node A (the one with a GPU) runs cells
        out = _reproduce(env, "--stages", GPU_STAGE, "--executor", "ray",
                         "--ray-address", cluster.address, "--gpus-per-cell", "1")
        got = _records(driver / "results")
        assert got, "no record came back to the driver's store: " + out[-2000:]
        assert set(got) <= set(expected)
        assert all(_same(got[k]["metrics"], expected[k]["metrics"]) for k in got)
        placement = re.findall(r"cells by node: (.*)", out)
        assert placement, out[-2000:]
        assert all(" 1 GPUs)" in part for part in placement[-1].split("; ")), placement
        assert list(tmp_b.glob("icil-cell-*")) == [] and not any(driver.glob("**/icil-cell-*"))

        # a node killed while it runs a cell: the cell runs again on the other node
        log = tmp_path / "kill-run.log"
        with open(log, "wb") as sink:
            run = subprocess.Popen([sys.executable, "-m", "icil_paper.cli", "reproduce",
                                    *SETTINGS, "--stages", KILL_STAGE, "--executor", "ray",
                                    "--ray-address", cluster.address], env=env,
                                   stdout=sink, stderr=subprocess.STDOUT)
        killed, end = None, time.time() + 300
        while killed is None and run.poll() is None and time.time() < end:
            for name, tmp in (("a", tmp_a), ("b", tmp_b)):
                if any(tmp.glob("icil-cell-*")):
                    cluster.kill(name)
                    killed = name
                    break
            time.sleep(0.2)
        run.wait(timeout=600)
        out = log.read_text(errors="replace")
        assert killed is not None, "no cell started on a node: " + out[-2000:]
        assert run.returncode == 0, out[-3000:]
        check_records(driver, expected)

        # a second run finds everything stored: no cell runs, no record changes
        before = {p: p.stat().st_mtime_ns for p in (driver / "results").rglob("*.json")}
        out = _reproduce(env, "--stages", GPU_STAGE, KILL_STAGE, "--executor", "ray",
                         "--ray-address", cluster.address)
        assert "cells (ray)" not in out
        assert {p: p.stat().st_mtime_ns for p in (driver / "results").rglob("*.json")} == before
    finally:
        cluster.stop()
        shutil.rmtree(cluster.root, ignore_errors=True)



def check_records(driver: Path, expected: dict[str, dict]) -> None:
    """Every record of the stages is in the driver's store, as the serial executor wrote it,
    and each train record with the policy file it names."""
    from icil_paper.results import files_problem

    got = _records(driver / "results")
    assert set(got) == set(expected)
    for key in expected:
        assert got[key]["config_hash"] == expected[key]["config_hash"]
        assert _same(got[key]["metrics"], expected[key]["metrics"]), key
    for key, record in got.items():
        if key.startswith("smoke/train/"):
            folder = driver / "runs" / "smoke" / record["metrics"]["run_dir"]
            assert files_problem(record, folder) is None, key
