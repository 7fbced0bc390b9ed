"""Throughput benchmarks (`make bench`): tokenizers, policies, simulators and the kitchen suite.

Each module runs as `python -m icil_paper.bench.<name>` and writes one JSON record to
`results/bench/<name>.json` through `save_benchmark`, which adds the provenance every result
carries (git commit, package versions, host, load average).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from icil_paper.fileio import atomic_write_json
from icil_paper.results import results_root
from icil_paper.setup.provenance import git_state, host_info, package_versions


def bench_path(name: str) -> Path:
    """`results/bench/<name>.json` of the results folder in use, else the one committed with
    the repository (the measurements a reader's own results folder does not hold)."""
    path = results_root() / "bench" / f"{name}.json"
    committed = Path(__file__).resolve().parents[3] / "results" / "bench" / f"{name}.json"
    return path if path.exists() else committed


def save_benchmark(name: str, record: dict[str, Any], out: str | Path | None = None) -> Path:
    """Add provenance to `record` and write it atomically to `out` (default
    results/bench/<name>.json); returns the path."""
    record = {"benchmark": name, **record, "load_average_1min": os.getloadavg()[0],
              "git": git_state(), "packages": package_versions(), "host": host_info()}
    path = Path(out) if out else results_root() / "bench" / f"{name}.json"
    atomic_write_json(path, record)
    print(f"wrote {path}")
    return path
