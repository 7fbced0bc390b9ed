"""The README's measured figures, computed from the records they quote.

    python -m icil_paper.bench.figures          # every figure with its value and source

A figure in the README is written as the number followed by a marker naming it,
`15.6 steps/s <!-- figure: policies.train_small_steps_per_s -->`, and
`tests/test_readme_figures.py` checks each printed number against `FIGURES` at the printed
precision (its significant digits), so a benchmark or reference record that changes
cannot leave an old number in the README.
"""

from __future__ import annotations

import json
import statistics
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
BENCH = ROOT / "results" / "bench"
REFERENCE = ROOT / "results" / "reference"


def _bench(name: str) -> dict:
    return json.loads((BENCH / f"{name}.json").read_text())


def _training(size: str, field: str) -> float:
    return next(t[field] for t in _bench("policies")["training"] if t["size"] == size)


def _latency(size: str, tokens: int, field: str) -> float:
    return next(t[field] for t in _bench("policies")["latency"]
                if t["size"] == size and t["prompt_tokens"] == tokens)


def _records(kind: str, prefix: str = "", tasks: str = "") -> list[dict]:
    """Reference records of `kind` whose file name starts with the policy label `prefix`
    (`icrt_lipvq`) and whose task tag starts with `tasks` (`kitchen` for a multi-task
    run, `kitchen_` for per-task evaluations)."""
    out = []
    for path in sorted((REFERENCE / kind).glob("*.json")):
        label, tag = path.name.split("__")[:2]
        if (not prefix or label == prefix) and tag.startswith(tasks) and (
                tasks.endswith("_") or not tasks or tag == tasks):
            out.append(json.loads(path.read_text()))
    return out


def _cell(kind: str, field: str) -> float:
    """A kind of cell's `seed_cost_s` or `floor_ratio` (its steady cell, the next seed in a
    worker that ran one), or `first_floor_ratio` (its first cell in a fresh process)."""
    cell = next(c for c in _bench("cells")["cells"] if c["kind"] == kind)
    return cell["first"]["floor_ratio"] if field == "first_floor_ratio" else cell[field]


def _compiled(kind: str, field: str) -> float:
    return next(c for c in _bench("cells")["compile"] if c["kind"] == kind)[field]


def _median_wall(kind: str, prefix: str, tasks: str) -> float:
    """Median `wall_time_s` of those records."""
    values = [r["wall_time_s"] for r in _records(kind, prefix, tasks)]
    if not values:
        raise ValueError(f"no reference {kind} record of {prefix} on {tasks}")
    return float(statistics.median(values))


def _span_hours() -> float:
    """From the start of the first reference record to the end of the last, in hours."""
    records = [r for kind in ("train", "eval", "features") for r in _records(kind)]
    ends = sorted((datetime.fromisoformat(r["finished"]), r["wall_time_s"]) for r in records)
    return ((ends[-1][0] - ends[0][0]).total_seconds() + ends[0][1]) / 3600


FIGURES: dict[str, tuple[str, Callable[[], float]]] = {
    "eval.policy_steps_per_s": ("results/bench/eval.json",
                                lambda: _bench("eval")["policy_steps_per_s"]),
    "eval.raw_steps_per_s": ("results/bench/eval.json", lambda: _bench("eval")["raw_steps_per_s"]),
    "eval.ratio": ("results/bench/eval.json", lambda: _bench("eval")["ratio"]),
    "eval.raw_worker_scaling": ("results/bench/eval.json",
                                lambda: _bench("eval")["raw_worker_scaling"]),
    "policies.train_small_steps_per_s": ("results/bench/policies.json",
                                         lambda: _training("small", "steps_per_s")),
    "policies.train_full_steps_per_s": ("results/bench/policies.json",
                                        lambda: _training("full", "steps_per_s")),
    "policies.train_full_s_per_step": ("results/bench/policies.json",
                                       lambda: _training("full", "s_per_step")),
    "policies.small_1600_cached_ms": ("results/bench/policies.json",
                                      lambda: _latency("small", 1600, "step_ms_kv_cache")),
    "policies.small_1600_recompute_ms": ("results/bench/policies.json",
                                         lambda: _latency("small", 1600, "step_ms_recompute")),
    "policies.full_1600_cached_ms": ("results/bench/policies.json",
                                     lambda: _latency("full", 1600, "step_ms_kv_cache")),
    "policies.full_1600_recompute_ms": ("results/bench/policies.json",
                                        lambda: _latency("full", 1600, "step_ms_recompute")),
    **{f"cells.{kind}.{field}": ("results/bench/cells.json",
                                 lambda kind=kind, field=field: _cell(kind, field))
       for kind in ("kitchen_icrt_lipvq", "bc_transformer", "act_maniskill", "kinova_eval")
       for field in ("seed_cost_s", "floor_ratio", "first_floor_ratio")},
    **{f"cells.compile.{kind}.{field}": ("results/bench/cells.json",
                                         lambda kind=kind, field=field: _compiled(kind, field))
       for kind in ("kitchen_icrt_lipvq", "act_maniskill")
       for field in ("eager_step_ms", "compiled_step_ms", "warmup_s")},
    "reference.icrt_train_s": ("results/reference/train",
                               lambda: _median_wall("train", "icrt_lipvq", "kitchen")),
    "reference.bc_eval_s": ("results/reference/eval",
                            lambda: _median_wall("eval", "bc_transformer", "kitchen_")),
    "reference.icrt_eval_s": ("results/reference/eval",
                              lambda: _median_wall("eval", "icrt_lipvq", "kitchen_")),
    "reference.bc_train_s": ("results/reference/train",
                             lambda: _median_wall("train", "bc_transformer", "kitchen")),
    "reference.act_train_s": ("results/reference/train",
                              lambda: _median_wall("train", "act", "kitchen")),
    "reference.mcr_eval_s": ("results/reference/eval",
                             lambda: _median_wall("eval", "mcr", "kitchen_")),
    "reference.span_hours": ("results/reference (finish times)", _span_hours),
}
"""Figure name -> (the records it comes from, a function computing it from them)."""


def figure(name: str) -> float:
    """The value of one README figure, computed from its records."""
    if name not in FIGURES:
        raise KeyError(f"unknown README figure {name!r} (known: {', '.join(FIGURES)})")
    return float(FIGURES[name][1]())


def main() -> None:
    for name, (source, _) in FIGURES.items():
        print(f"{name:40s} {figure(name):12.4g}   {source}")


if __name__ == "__main__":
    main()
