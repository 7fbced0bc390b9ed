"""The executors of `tables.cells.run_jobs`: serial, local pool and Ray give the same
records; dead workers are retried, raising jobs are reported, finished jobs are skipped,
and Ray tasks share no files with the driver."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import grid_cells
from grid_cells import call
from icil_paper.results import ResultsStore
from icil_paper.tables.cells import CellsFailed, Job, RayUnavailable, connect_ray, run_jobs


def _use_folder(tmp_path: Path, monkeypatch, tag: str) -> Path:
    """A fresh results folder for one run (workers get it from the driver); its calls folder."""
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / tag / "results"))
    return tmp_path / tag / "calls"


def _folders() -> dict[str, str]:
    return {"ICIL_RESULTS": os.environ["ICIL_RESULTS"]}


def _draws(calls: Path, n: int = 4) -> list[Job]:
    return [grid_cells.job("draw", f"c{i}", seed=i, calls_dir=str(calls)) for i in range(n)]


def _records() -> dict[str, tuple[str, dict]]:
    return {r["name"]: (r["config_hash"], r["metrics"])
            for r in ResultsStore("smoke").records(grid_cells.KIND)}


def _calls(calls: Path, name: str) -> list[Path]:
    return sorted(calls.glob(f"{name}.*"))


def _serial_reference(tmp_path: Path, monkeypatch) -> tuple[dict, dict]:
    calls = _use_folder(tmp_path, monkeypatch, "serial")
    results = run_jobs(call, _draws(calls), executor="serial", progress=False)
    return results, _records()


def _metrics(results: dict) -> dict:
    return {k: r["metrics"] for k, r in results.items()}


def test_jobs_are_checked():
    job = grid_cells.job("draw", "a", seed=0, calls_dir="x")
    with pytest.raises(ValueError, match="same key"):
        run_jobs(call, [job, job], executor="serial", progress=False)
    with pytest.raises(ValueError, match="unknown executor"):
        run_jobs(call, [job], executor="threads", progress=False)


def test_local_pool_gives_the_serial_records(tmp_path, monkeypatch):
    import torch

    torch.set_num_threads(2)  # the caller's setting; jobs run on one thread and restore it
    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    assert torch.get_num_threads() == 2
    calls = _use_folder(tmp_path, monkeypatch, "local")
    local = run_jobs(call, _draws(calls), executor="local", workers=2, progress=False)

    assert _records() == serial_records and len(serial_records) == 4
    assert list(local) == list(serial)  # the jobs' order
    assert _metrics(local) == _metrics(serial)
    assert all(r["metrics"]["torch_threads"] == 1 for r in [*serial.values(), *local.values()])
    pids = {r["pid"] for r in local.values()}
    assert len(pids) == 2 and os.getpid() not in pids  # two worker processes, not this one


def test_local_pool_retries_dead_workers_and_reports_failures(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "local")
    jobs = [grid_cells.job("always_dies", "x", calls_dir=str(calls)),
            grid_cells.job("die_once", "k", seed=2, calls_dir=str(calls), how="kill"),
            grid_cells.job("raises", "bad", calls_dir=str(calls)),
            grid_cells.job("die_once", "e", seed=3, calls_dir=str(calls), how="exit"),
            *_draws(calls, 2)]
    with pytest.raises(CellsFailed) as err:
        run_jobs(call, jobs, executor="local", workers=2, retries=1, progress=False)

    # one line per failed job, in the jobs' order, naming it by its label
    assert str(err.value).splitlines() == [
        "2 of 6 cells failed:",
        "  always_dies x: the worker process died (in each of 2 attempts)",
        "  raises bad: ValueError: bad input for bad"]
    assert [f.attempts for f in err.value.failures] == [2, 1]
    assert "Traceback" in err.value.failures[1].detail
    assert len(_calls(calls, "x")) == 2  # retried once, then given up
    assert len(_calls(calls, "bad")) == 1  # an exception is not retried
    # the killed jobs ran again in a fresh process and finished, as did the others
    results = err.value.results
    assert set(results) == {j.key for j in jobs} - {"always_dies-x", "raises-bad"}
    for name, seed in [("k", 2), ("e", 3)]:
        first, second = _calls(calls, name)
        assert results[f"die_once-{name}"]["pid"] == int(second.read_text())
        assert int(first.read_text()) != int(second.read_text())
        assert _records()[name][1] == {"seed_squared": seed * seed}
    assert set(_records()) == {"k", "e", "c0", "c1"}  # stored before the error was raised


def test_a_worker_past_its_memory_limit_is_replaced_before_its_next_job(tmp_path,
                                                                        monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "high")
    jobs = [*_draws(calls, 2), grid_cells.job("hold", "big", calls_dir=str(calls), gib=0.5),
            *_draws(calls, 4)[2:]]
    results = list(run_jobs(call, jobs, workers=1, recycle_gb=64.0, progress=False).values())
    assert len({r["pid"] for r in results}) == 1  # under the limit: one worker throughout
    # a limit above what a worker holds after the light jobs (its imports), below what it
    # holds after the heavy one
    limit = max(r["rss_gb"] for r in results[:2]) + 0.25
    _use_folder(tmp_path, monkeypatch, "limit")  # a fresh store: every job runs again
    pids = [r["pid"] for r in run_jobs(call, jobs, workers=1, recycle_gb=limit,
                                       progress=False).values()]
    # the heavy job runs on the same worker as the light ones, which is then replaced; the
    # next worker keeps its light jobs
    assert pids[0] == pids[1] == pids[2] != pids[3] == pids[4]


def test_serial_reports_a_raising_job_and_finishes_the_others(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "serial")
    jobs = [grid_cells.job("raises", "bad", calls_dir=str(calls)), *_draws(calls, 2)]
    with pytest.raises(CellsFailed, match="raises bad: ValueError: bad input for bad$") as err:
        run_jobs(call, jobs, executor="serial", progress=False)
    assert set(err.value.results) == {"draw-c0", "draw-c1"}
    assert set(_records()) == {"c0", "c1"}


def test_a_script_without_a_main_guard_gets_a_clear_error(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text("import json\nfrom icil_paper.tables.cells import Job, run_jobs\n"
                      "run_jobs(json.dumps, [Job('a', 'a', {'obj': 1})], retries=0, "
                      "progress=False)\n")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 1
    assert "if __name__ == '__main__':" in out.stderr  # the standard library's advice
    last = out.stderr.strip().splitlines()[-1]
    assert last == "  a: the worker process died (in each of 1 attempts)"


def test_done_skips_finished_jobs(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "local")
    jobs = _draws(calls, 3)
    run_jobs(call, jobs, executor="serial", done=grid_cells.stored, progress=False)
    before = sorted(calls.iterdir())
    assert len(before) == 3

    assert run_jobs(call, jobs, executor="local", done=grid_cells.stored, progress=False) == {}
    assert sorted(calls.iterdir()) == before  # no function was called

    next((ResultsStore("smoke").dir / grid_cells.KIND).glob("c1__*.json")).unlink()
    rerun = run_jobs(call, jobs, executor="serial", done=grid_cells.stored, progress=False)
    assert list(rerun) == ["draw-c1"] and len(_calls(calls, "c1")) == 2
    assert len(_calls(calls, "c0")) == len(_calls(calls, "c2")) == 1


# --------------------------------------------------------------------------- Ray
# One Ray session for the module (a local Ray takes 10-25 s to start on 2 busy cores);
# run_jobs uses a session the caller opened and leaves it open. Every Ray task works in
# private folders and returns its files, which the driver writes into its own.
@pytest.fixture(scope="module")
def ray_session():
    ray = pytest.importorskip("ray", reason="Ray is not installed")
    if ray.is_initialized():
        pytest.skip("a Ray session is already open in this process")
    try:
        started = connect_ray(workers=2)
    except RayUnavailable as exc:
        pytest.skip(f"Ray cannot start here: {exc}")
    yield ray
    if started:
        ray.shutdown()


@pytest.mark.slow
@pytest.mark.ray
def test_ray_gives_the_serial_records_and_retries_a_killed_worker(tmp_path, monkeypatch,
                                                                   ray_session):
    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    calls = _use_folder(tmp_path, monkeypatch, "ray")
    jobs = [*_draws(calls),
            grid_cells.job("die_once", "k", seed=2, calls_dir=str(calls), how="kill"),
            grid_cells.job("die_once", "e", seed=3, calls_dir=str(calls), how="exit")]
    results = run_jobs(call, jobs, executor="ray", retries=2, folders=_folders(),
                       progress=False)

    assert ray_session.is_initialized()  # the caller's session stays open
    assert set(results) == {j.key for j in jobs}
    assert {k: v for k, v in _records().items() if k.startswith("c")} == serial_records
    assert _metrics({k: results[k] for k in serial}) == _metrics(serial)
    for name, seed in [("k", 2), ("e", 3)]:
        first, second = _calls(calls, name)
        assert results[f"die_once-{name}"]["pid"] == int(second.read_text())
        assert int(first.read_text()) != int(second.read_text())
        assert _records()[name][1] == {"seed_squared": seed * seed}


@pytest.mark.slow
@pytest.mark.ray
def test_ray_reports_a_raising_job_and_skips_stored_ones(tmp_path, monkeypatch, ray_session):
    calls = _use_folder(tmp_path, monkeypatch, "ray")
    jobs = [grid_cells.job("raises", "bad", calls_dir=str(calls)), *_draws(calls, 2)]
    with pytest.raises(CellsFailed, match="raises bad: ValueError: bad input for bad") as err:
        run_jobs(call, jobs, executor="ray", folders=_folders(), done=grid_cells.stored,
                 progress=False)
    assert len(_calls(calls, "bad")) == 1
    assert set(err.value.results) == {"draw-c0", "draw-c1"}
    assert set(_records()) == {"c0", "c1"}
    assert run_jobs(call, jobs[1:], executor="ray", folders=_folders(),
                    done=grid_cells.stored, progress=False) == {}


@pytest.mark.slow
@pytest.mark.ray
def test_ray_started_for_the_jobs_is_shut_down_after_them(tmp_path, monkeypatch, ray_session):
    from icil_paper.tables import cells

    calls = _use_folder(tmp_path, monkeypatch, "ray")
    shutdowns = []
    monkeypatch.setattr(cells, "connect_ray", lambda *a: True)  # as if it started this Ray
    monkeypatch.setattr(ray_session, "shutdown", lambda: shutdowns.append(1))
    run_jobs(call, _draws(calls, 1), executor="ray", folders=_folders(), progress=False)
    assert shutdowns == [1]


# --------------------------------------------------------------------------- no shared files
def test_a_ray_task_works_in_private_folders_and_its_records_come_back(tmp_path,
                                                                      monkeypatch):
    """`_on_node`, called here as a Ray task runs it (its inputs given as bytes)."""
    from icil_paper.tables import cells

    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    driver = tmp_path / "driver" / "results"
    monkeypatch.setenv("ICIL_RESULTS", str(driver))
    monkeypatch.setattr(cells, "_fetch", lambda blob: blob)
    folders = {"ICIL_RESULTS": str(driver)}
    jobs = _draws(tmp_path / "detached" / "calls")
    for job in jobs:
        before = sorted(driver.rglob("*"))
        answer = cells._on_node(call, job.kwargs, {}, list(folders), [],
                                cells.read_inputs(job, folders))
        assert sorted(driver.rglob("*")) == before  # it wrote only into its private folder
        assert answer["result"]["metrics"] == serial[job.key]["metrics"]
        assert [f[1].split("/")[:2] for f in answer["files"]] == [["smoke", grid_cells.KIND]]
        assert cells.install_files(answer["files"], folders) == 1
    assert _records() == serial_records
    # a job sent its stored record finds it there: nothing computed, nothing comes back
    stored = ResultsStore("smoke").record_path(grid_cells.KIND, "c0", {"name": "c0", "seed": 0})
    job = Job("again", "again", jobs[0].kwargs,
              inputs={"ICIL_RESULTS": (stored.relative_to(driver).as_posix(),)})
    answer = cells._on_node(call, job.kwargs, {}, list(folders), [],
                            cells.read_inputs(job, folders))
    assert answer["files"] == [] and len(_calls(tmp_path / "detached" / "calls", "c0")) == 2


def test_returned_files_are_checked_before_any_is_written(tmp_path):
    import hashlib
    import json

    from icil_paper.tables.cells import install_files

    folders = {"ICIL_RESULTS": str(tmp_path / "results"), "ICIL_RUNS": str(tmp_path / "runs")}
    policy = b"weights"
    digest = hashlib.sha256(policy).hexdigest()
    record = json.dumps({"files": {"policy.pt": digest}}).encode()
    good = [("ICIL_RUNS", "smoke/run1/policy.pt", digest, policy),
            ("ICIL_RESULTS", "smoke/train/r.json", hashlib.sha256(record).hexdigest(), record)]
    damaged = [good[0][:3] + (b"weightz",), good[1]]
    with pytest.raises(ValueError, match="damaged"):
        install_files(damaged, folders)
    with pytest.raises(ValueError, match="did not come back"):
        install_files(good[1:], folders)  # a record without the file it names
    with pytest.raises(ValueError, match="inside its folder"):
        install_files([("ICIL_RUNS", "../evil", digest, policy)], folders)
    assert not any(tmp_path.rglob("*.*"))  # nothing written by a refused answer
    assert install_files(good, folders) == 2
    assert (tmp_path / "runs/smoke/run1/policy.pt").read_bytes() == policy
    assert json.loads((tmp_path / "results/smoke/train/r.json").read_text())["files"]
