"""The grid executor: serial, local pool and Ray give the same records; dead workers are
retried, raising cells are reported, finished cells are skipped."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import grid_cells
from icil_paper.results import ResultsStore
from icil_paper.tables.grid import Cell, GridError, RayUnavailable, connect_ray, run_grid


def _use_folder(tmp_path: Path, monkeypatch, tag: str) -> Path:
    """A fresh results folder for one run (workers get it from the driver); its calls folder."""
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / tag / "results"))
    return tmp_path / tag / "calls"


def _draws(calls: Path, n: int = 4) -> list[Cell]:
    return [grid_cells.cell("draw", f"c{i}", seed=i, calls_dir=str(calls)) for i in range(n)]


def _records() -> dict[str, tuple[str, dict]]:
    return {r["name"]: (r["config_hash"], r["metrics"])
            for r in ResultsStore("smoke").records(grid_cells.KIND)}


def _calls(calls: Path, name: str) -> list[Path]:
    return sorted(calls.glob(f"{name}.*"))


def _serial_reference(tmp_path: Path, monkeypatch) -> tuple[dict, dict]:
    calls = _use_folder(tmp_path, monkeypatch, "serial")
    results = run_grid(_draws(calls), executor="serial", progress=False)
    return results, _records()


def test_cell_checks_its_fields():
    with pytest.raises(ValueError, match="module:function"):
        Cell(key="a", target="no_colon")
    with pytest.raises(ValueError, match="plain JSON"):
        Cell(key="a", target="m:f", kwargs={"path": Path("x")})
    with pytest.raises(ValueError, match="cpus"):
        Cell(key="a", target="m:f", cpus=0)
    cell = Cell(key="a", target="m:f", kwargs={"pair": (1, 2)})
    assert cell.label == "a" and cell.kwargs == {"pair": [1, 2]}  # what every worker sees
    with pytest.raises(ValueError, match="two cells have the key"):
        run_grid([cell, cell], executor="serial", progress=False)


def test_local_pool_gives_the_serial_records(tmp_path, monkeypatch):
    import torch

    torch.set_num_threads(2)  # the caller's setting; cells run on one thread and restore it
    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    assert torch.get_num_threads() == 2
    calls = _use_folder(tmp_path, monkeypatch, "local")
    local = run_grid(_draws(calls), executor="local", workers=2, progress=False)

    assert _records() == serial_records and len(serial_records) == 4
    assert list(local) == list(serial)  # the grid's order
    assert {k: r["metrics"] for k, r in local.items()} == {k: r["metrics"]
                                                           for k, r in serial.items()}
    assert all(r["metrics"]["torch_threads"] == 1 for r in [*serial.values(), *local.values()])
    pids = {r["pid"] for r in local.values()}
    assert len(pids) == 2 and os.getpid() not in pids  # two worker processes, not this one


def test_local_pool_retries_dead_workers_and_reports_failures(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "local")
    cells = [grid_cells.cell("always_dies", "x", calls_dir=str(calls)),
             grid_cells.cell("die_once", "k", seed=2, calls_dir=str(calls), how="kill"),
             grid_cells.cell("raises", "bad", calls_dir=str(calls)),
             grid_cells.cell("die_once", "e", seed=3, calls_dir=str(calls), how="exit"),
             *_draws(calls, 2)]
    with pytest.raises(GridError) as err:
        run_grid(cells, executor="local", workers=2, retries=1, progress=False)

    # one line per failed cell, in the grid's order, naming it by its label
    assert str(err.value).splitlines() == [
        "2 of 6 cells failed:",
        "  always_dies x: the worker process exited with code 3 (in each of 2 attempts)",
        "  raises bad: ValueError: bad input for bad"]
    assert [f.attempts for f in err.value.failures] == [2, 1]
    assert "Traceback" in err.value.failures[1].detail
    assert len(_calls(calls, "x")) == 2  # retried once, then given up
    assert len(_calls(calls, "bad")) == 1  # an exception is not retried
    # the killed cells ran again in a fresh process and finished, as did the others
    results = err.value.results
    assert set(results) == {c.key for c in cells} - {"always_dies-x", "raises-bad"}
    for name, seed in [("k", 2), ("e", 3)]:
        first, second = _calls(calls, name)
        assert results[f"die_once-{name}"]["pid"] == int(second.read_text())
        assert int(first.read_text()) != int(second.read_text())
        assert _records()[name][1] == {"seed_squared": seed * seed}
    assert set(_records()) == {"k", "e", "c0", "c1"}  # stored before the error was raised


def test_a_worker_past_its_memory_limit_is_replaced_before_its_next_cell(tmp_path,
                                                                          monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "high")
    cells = [*_draws(calls, 2), grid_cells.cell("hold", "big", calls_dir=str(calls), gib=2.0),
             *_draws(calls, 4)[2:]]
    results = list(run_grid(cells, workers=1, recycle_gb=64.0, progress=False).values())
    assert len({r["pid"] for r in results}) == 1  # under the limit: one worker throughout
    # a limit above what a worker holds after the light cells (its imports), below what it
    # holds after the heavy one
    limit = max(r["rss_gb"] for r in results[:2]) + 0.75
    _use_folder(tmp_path, monkeypatch, "limit")  # a fresh store: every cell runs again
    pids = [r["pid"] for r in run_grid(cells, workers=1, recycle_gb=limit,
                                       progress=False).values()]
    # the heavy cell runs on the same worker as the light ones, which is then replaced; the
    # next worker keeps its light cells
    assert pids[0] == pids[1] == pids[2] != pids[3] == pids[4]
    with pytest.raises(ValueError, match="recycle_gb"):
        run_grid(cells, workers=1, recycle_gb=0, progress=False)


def test_serial_reports_a_raising_cell_and_finishes_the_others(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "serial")
    cells = [grid_cells.cell("raises", "bad", calls_dir=str(calls)), *_draws(calls, 2)]
    with pytest.raises(GridError, match="raises bad: ValueError: bad input for bad$") as err:
        run_grid(cells, executor="serial", progress=False)
    assert set(err.value.results) == {"draw-c0", "draw-c1"}
    assert set(_records()) == {"c0", "c1"}


def test_a_script_without_a_main_guard_gets_a_clear_error(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text("from icil_paper.tables.grid import Cell, run_grid\n"
                      "run_grid([Cell(key='a', target='json:dumps', kwargs={'obj': 1})], "
                      "progress=False)\n")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 1
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("RuntimeError: a grid worker process exited with code 1 before")
    assert "if __name__ == '__main__':" in last


def test_done_skips_finished_cells(tmp_path, monkeypatch):
    calls = _use_folder(tmp_path, monkeypatch, "local")
    cells = _draws(calls, 3)
    run_grid(cells, executor="serial", done=grid_cells.stored, progress=False)
    before = sorted(calls.iterdir())
    assert len(before) == 3

    assert run_grid(cells, executor="local", done=grid_cells.stored, progress=False) == {}
    assert sorted(calls.iterdir()) == before  # no function was called

    next((ResultsStore("smoke").dir / grid_cells.KIND).glob("c1__*.json")).unlink()
    rerun = run_grid(cells, executor="serial", done=grid_cells.stored, progress=False)
    assert list(rerun) == ["draw-c1"] and len(_calls(calls, "c1")) == 2
    assert len(_calls(calls, "c0")) == len(_calls(calls, "c2")) == 1


# --------------------------------------------------------------------------- Ray
# The first test starts (and stops) its own Ray through run_grid; the later ones share one
# session (a local Ray takes 10-25 s to start on 2 busy cores), which run_grid leaves open.
@pytest.mark.slow
@pytest.mark.ray
def test_ray_gives_the_serial_records_and_shuts_down(tmp_path, monkeypatch):
    ray = pytest.importorskip("ray", reason="Ray is not installed")
    if ray.is_initialized():
        pytest.skip("a Ray session is already open in this process")
    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    calls = _use_folder(tmp_path, monkeypatch, "ray")
    try:
        results = run_grid(_draws(calls), executor="ray", workers=2, progress=False)
    except RayUnavailable as exc:
        pytest.skip(f"Ray cannot start here: {exc}")

    assert not ray.is_initialized()  # the Ray it started is shut down
    assert _records() == serial_records
    assert {k: r["metrics"] for k, r in results.items()} == {k: r["metrics"]
                                                             for k, r in serial.items()}


@pytest.fixture(scope="module")
def ray_session():
    ray = pytest.importorskip("ray", reason="Ray is not installed")
    try:
        started = connect_ray(workers=2)
    except RayUnavailable as exc:
        pytest.skip(f"Ray cannot start here: {exc}")
    yield ray
    if started:
        ray.shutdown()


@pytest.mark.slow
@pytest.mark.ray
def test_ray_retries_a_killed_worker(tmp_path, monkeypatch, ray_session):
    calls = _use_folder(tmp_path, monkeypatch, "ray")
    cells = [*_draws(calls, 2),
             grid_cells.cell("die_once", "k", seed=2, calls_dir=str(calls), how="kill"),
             grid_cells.cell("die_once", "e", seed=3, calls_dir=str(calls), how="exit")]
    results = run_grid(cells, executor="ray", retries=2, progress=False)

    assert set(results) == {c.key for c in cells}
    assert ray_session.is_initialized()  # the caller's session stays open
    for name, seed in [("k", 2), ("e", 3)]:
        first, second = _calls(calls, name)
        assert results[f"die_once-{name}"]["pid"] == int(second.read_text())
        assert int(first.read_text()) != int(second.read_text())
        assert _records()[name][1] == {"seed_squared": seed * seed}


@pytest.mark.slow
@pytest.mark.ray
def test_ray_reports_a_raising_cell(tmp_path, monkeypatch, ray_session):
    calls = _use_folder(tmp_path, monkeypatch, "ray")
    cells = [grid_cells.cell("raises", "bad", calls_dir=str(calls)), *_draws(calls, 2)]
    with pytest.raises(GridError, match="raises bad: ValueError: bad input for bad") as err:
        run_grid(cells, executor="ray", progress=False)
    assert len(_calls(calls, "bad")) == 1
    assert set(err.value.results) == {"draw-c0", "draw-c1"}
    assert set(_records()) == {"c0", "c1"}


# --------------------------------------------------------------------------- no shared files
def test_a_detached_cell_works_in_private_folders_and_its_records_come_back(tmp_path,
                                                                           monkeypatch):
    from icil_paper.tables.grid import _execute_detached, _job, install_files, read_inputs

    serial, serial_records = _serial_reference(tmp_path, monkeypatch)
    driver = tmp_path / "driver" / "results"
    monkeypatch.setenv("ICIL_RESULTS", str(driver))
    folders = {"ICIL_RESULTS": str(driver)}
    job = {**_job(1), "folders": list(folders)}
    cells = _draws(tmp_path / "detached" / "calls")
    for cell in cells:
        before = sorted(driver.rglob("*"))
        answer = _execute_detached(cell.target, cell.kwargs, job, read_inputs(cell, folders))
        assert sorted(driver.rglob("*")) == before  # it wrote only into its private folder
        assert answer["result"]["metrics"] == serial[cell.key]["metrics"]
        assert [f[1].split("/")[:2] for f in answer["files"]] == [["smoke", grid_cells.KIND]]
        assert install_files(answer["files"], folders) == 1
    assert _records() == serial_records
    # a cell sent its stored record finds it there: nothing computed, nothing comes back
    stored = ResultsStore("smoke").record_path(grid_cells.KIND, "c0", {"name": "c0", "seed": 0})
    cell = Cell(key="again", target=cells[0].target, kwargs=cells[0].kwargs,
                inputs={"ICIL_RESULTS": (stored.relative_to(driver).as_posix(),)})
    answer = _execute_detached(cell.target, cell.kwargs, job, read_inputs(cell, folders))
    assert answer["files"] == [] and len(_calls(tmp_path / "detached" / "calls", "c0")) == 2


def test_returned_files_are_checked_before_any_is_written(tmp_path):
    import hashlib
    import json

    from icil_paper.tables.grid import install_files

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
