"""Throughput benchmarks, one module each: `make bench` runs them all from the repository root
as `python -m tools.bench.<name>`. Each writes `results/bench/<name>.json` with its
provenance (`icil_paper.results.save_benchmark`)."""
