"""Kept only for `planning/pilot.py`, which imports its record helpers from here: they live
in `icil_paper.results` now, and the benchmarks in `tools/bench/`. Remove this package when
pilot.py imports them from `icil_paper.results`."""

from icil_paper.results import bench_path, save_benchmark

__all__ = ["bench_path", "save_benchmark"]
