"""Tiny jobs for tests/test_grid.py, importable by spawned and Ray workers.

Each cell stores a `grid` record through `ResultsStore` (the folder `ICIL_RESULTS` names)
and leaves one file per call in `calls_dir`, so a test can count how often, and in which
process, each cell ran.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

from icil_paper.results import ResultsStore
from icil_paper.seeding import seed_everything
from icil_paper.tables.cells import Job

KIND = "grid"


def _config(name: str, seed: int) -> dict:
    return {"name": name, "seed": seed}


def _count_call(calls_dir: str, name: str) -> int:
    """Leave a marker of this call; return its attempt number (1 for the first)."""
    folder = Path(calls_dir)
    folder.mkdir(parents=True, exist_ok=True)
    n = len(list(folder.glob(f"{name}.*"))) + 1
    (folder / f"{name}.{n}").write_text(str(os.getpid()))
    return n


def draw(name: str, seed: int, calls_dir: str) -> dict:
    """Seeded NumPy and torch draws, stored as metrics; returns the record's metrics."""
    import torch

    _count_call(calls_dir, name)

    def compute() -> dict:
        rng = seed_everything(seed)
        w = torch.randn(32, 32)
        x = torch.randn(8, 32)
        return {"numpy_mean": float(rng.normal(size=256).mean()),
                "torch_sum": float((x @ w).tanh().sum()),
                "torch_threads": torch.get_num_threads()}

    record = ResultsStore("smoke").run(KIND, name, _config(name, seed), compute, seed=seed)
    return {"metrics": record["metrics"], "pid": os.getpid(), "rss_gb": resident_gb()}


def resident_gb() -> float:
    """This process's resident memory now, in GiB."""
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**30


def die_once(name: str, seed: int, calls_dir: str, how: str = "exit") -> dict:
    """The first call kills its own process (`how`: "exit" or "kill"); later calls store."""
    if _count_call(calls_dir, name) == 1:
        sys.stdout.flush()
        if how == "kill":
            os.kill(os.getpid(), signal.SIGKILL)
        os._exit(3)
    record = ResultsStore("smoke").run(KIND, name, _config(name, seed),
                                       lambda: {"seed_squared": seed * seed}, seed=seed)
    return {"metrics": record["metrics"], "pid": os.getpid()}


_KEPT: list[bytes] = []  # what `hold` leaves behind in its process


def hold(name: str, calls_dir: str, gib: float) -> dict:
    """Touch `gib` GiB and keep it after returning, as a cell whose allocator does not give
    its memory back (the process's resident memory stays that much higher); store
    nothing."""
    _count_call(calls_dir, name)
    _KEPT.append(b"\x01" * int(gib * 1024 ** 3))  # written, so resident
    return {"bytes": len(_KEPT[-1]), "pid": os.getpid()}


def always_dies(name: str, calls_dir: str) -> dict:
    _count_call(calls_dir, name)
    os._exit(3)


def raises(name: str, calls_dir: str) -> dict:
    _count_call(calls_dir, name)
    raise ValueError(f"bad input for {name}\nsecond line of the message")


FUNCTIONS = {"draw": draw, "die_once": die_once, "hold": hold, "always_dies": always_dies,
             "raises": raises}


def job(fn: str, name: str, **kwargs) -> Job:
    """A test job named after `fn`; run it with `run_jobs(call, ...)`."""
    return Job(key=f"{fn}-{name}", label=f"{fn} {name}", kwargs={"fn": fn, "name": name, **kwargs})


def call(fn: str, **kwargs) -> dict:
    """The function of every test job: `FUNCTIONS[fn](**kwargs)`."""
    return FUNCTIONS[fn](**kwargs)


def stored(j: Job) -> bool:
    """The `done` predicate of these jobs: the store holds the job's record."""
    config = _config(j.kwargs["name"], j.kwargs.get("seed", 0))
    return ResultsStore("smoke").get(KIND, j.kwargs["name"], config) is not None
