"""Shared test setup: every test runs with the smoke preset and a private results folder."""

from __future__ import annotations

import fcntl
import gc
import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

# The files that take longest, longest first (measured under `make test`). `make test` hands whole
# files to its two workers in collection order (`--dist loadfile --no-loadscope-reorder`; by
# default pytest-xdist would order them by their number of tests, which sent the few-test,
# minute-long files last, to run alone at the end while the other worker idled). Ray's files
# (marked `ray`: test_cluster, test_tables, test_plugins, test_grid) alternate with others, so
# that the workers rarely wait on each other's Ray. Every other file follows, alphabetically.
SLOWEST_FILES = ("test_cluster.py", "test_browser_check.py", "test_rollouts.py", "test_tables.py",
                 "test_maniskill.py", "test_plugins.py", "test_motion.py", "test_grid.py",
                 "test_reliability.py", "test_one_writer.py", "test_evaluate.py",
                 "test_official_code.py", "test_staged.py", "test_scene_shift.py")


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: a file's order kept


@pytest.fixture(autouse=True, scope="module")
def _one_ray_at_a_time(request, tmp_path_factory):
    """`make test` runs the files on both cores (pytest-xdist, `-n 2 --dist loadfile`: a
    file's module-scoped fixtures are built once, on one worker). A file with tests marked
    `ray` holds a lock shared by the workers while it runs, so that two local Rays never
    start at once: on 2 busy cores the second one's raylet misses Ray's 30 s start-up limit."""
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if worker is None or not any(item.get_closest_marker("ray") for item in request.session.items
                                 if item.module is request.module):
        yield
        return
    lock = tmp_path_factory.getbasetemp().parent / "ray.lock"  # the workers' common folder
    with open(lock, "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture()
def folders(tmp_path, monkeypatch):
    """Private data, runs and results folders (none exists yet), for tests of commands."""
    out = {name: tmp_path / name for name in ("data", "runs", "results")}
    monkeypatch.setenv("ICIL_DATA", str(out["data"]))
    monkeypatch.setenv("ICIL_RUNS", str(out["runs"]))
    monkeypatch.setenv("ICIL_RESULTS", str(out["results"]))
    return out


@pytest.fixture(autouse=True)
def _isolated_results(tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "results"))
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    monkeypatch.setenv("ICIL_PRESET", "smoke")


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny models run fastest (and with steady timings) on one torch thread."""
    try:
        import torch
    except ImportError:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture(autouse=True)
def _collector_skips_what_the_test_starts_with():
    """The simulators run a full `gc.collect()` on their own: ManiSkill at every scene rebuild
    (each seeded reset), robosuite when it frees a sim. A full collection walks every object of
    the process, about 0.5 s with torch and SAPIEN loaded. Frozen for the test's duration
    (`gc.freeze`, constant time), the objects alive when the test starts (imports, module
    fixtures) are left out of those walks; unfrozen at its end, they are collected as before."""
    gc.freeze()
    yield
    gc.unfreeze()
