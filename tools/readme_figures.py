"""The measured figures of the README and CONTRIBUTING.md, computed from the records they
quote.

    python -m tools.readme_figures                  # every figure with its value and source
    python -m tools.readme_figures --update-readme  # rewrite both files' figures

A figure in either file (`DOCUMENTS`) is written as the number followed by a marker naming it,
`15.6 steps/s <!-- figure: policies.train_small_steps_per_s -->`, and
`tests/test_readme_figures.py` (part of `make test`) checks each printed number against
`FIGURES` at the printed precision (its significant digits), so a benchmark or reference
record that changes cannot leave an old number in the README.
"""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from icil_paper.book.report import decision_rate
from icil_paper.config import get_preset
from icil_paper.stats import Verdict
from icil_paper.tables.claims import summary

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "results" / "bench"
REFERENCE = ROOT / "results" / "reference"
OLDER = REFERENCE / "older-code"
"""The older protocol's reference records, ledger, cost and plan."""
KITCHEN = OLDER / "kitchen"
"""The kitchen run's ledger, cost and design record (the run before the one on Meta-World)."""
OLDER_COST = "results/reference/older-code/cost.json"
KITCHEN_COST = "results/reference/older-code/kitchen/cost.json"
COST = "results/reference/cost.json"
PLAN = "results/reference/plan.json"
DOCUMENTS = (ROOT / "README.md", ROOT / "CONTRIBUTING.md")
"""The files whose measured figures carry markers."""


def _bench(name: str) -> dict:
    return json.loads((BENCH / f"{name}.json").read_text())


def _training(size: str, field: str, bench: str = "policies") -> float:
    return next(t[field] for t in _bench(bench)["training"] if t["size"] == size)


def _latency(size: str, tokens: int, field: str, bench: str = "policies") -> float:
    return next(t[field] for t in _bench(bench)["latency"]
                if t["size"] == size and t["prompt_tokens"] == tokens)


def _cell(kind: str, field: str) -> float:
    """A kind of cell's `seed_cost_s` or `floor_ratio` (its steady cell, the next seed in a
    worker that ran one), or `first_floor_ratio` (its first cell in a fresh process)."""
    cell = next(c for c in _bench("cells")["cells"] if c["kind"] == kind)
    return cell["first"]["floor_ratio"] if field == "first_floor_ratio" else cell[field]


def _cost(folder: Path) -> dict[str, Any]:
    """A reference run's `cost.json` (`python -m icil_paper.planning.cost`) in `folder`: the
    current run's (`REFERENCE`) or an earlier run's (`KITCHEN`, `OLDER`)."""
    return json.loads((folder / "cost.json").read_text())


def _plan(field: str, folder: Path) -> float:
    """A run's plan for its undecided claims (`icil-paper plan`, written to `plan.json`; the
    older protocol's kept in `older-code/`): `cores`, the number of `undecided` claims it
    lists and of those it `planned` (the others need more seeds than a preset has data sets
    for), or the `cells`, `cpu_hours` and `wall_hours` at `cores` of their missing cells."""
    plan = json.loads((folder / "plan.json").read_text())
    if field == "cores":
        return plan["cores"]
    if field == "undecided":
        return len(plan["claims"])
    if field == "planned":
        return sum(1 for c in plan["claims"] if c["planned"])
    return plan["total"][field]  # each cell once, though claims may share it


def _cost_hours(field: str, folder: Path) -> float:
    """Hours of a reference run (`_cost`'s `folder`): `elapsed` (the sittings' elapsed times
    summed: the machine's hours), `wall` (every record's wall time summed: cell-hours) or
    `cpu`."""
    cost = _cost(folder)
    if field == "elapsed":
        return sum(s["elapsed_s"] for s in cost["sittings"]) / 3600
    return cost["total"][f"{field}_s"] / 3600


def _claims(field: str, ledger: str = "claims.json") -> int:
    """A count of the reference ledger's `summary` (after Holm's correction): `claims`, a
    verdict (`holds`, `does not hold`, `not run`), `undecided` or `size_excluded`; `ledger`
    under `results/reference/` (`older-code/claims.json`: the older code's)."""
    s = summary(json.loads((REFERENCE / ledger).read_text())["claims"])
    return s["counts"][field] if field in s["counts"] else s[field]


CONCLUSION_CLAIMS = ("I-lipvq-vs-bc", "I-lipvq-vs-lfq", "I-lipvq-best", "II-lipvq-vs-act",
                     "V-lipvq-vs-bc", "beyond-eq4-rvq")
"""The success-difference claims the README's conclusion quotes."""


def _claim_points(claim_id: str, field: str) -> float:
    """One claim's success difference in points from the reference ledger: `ours` (this
    run's estimate) or `paper` (the paper's number)."""
    claims = json.loads((REFERENCE / "claims.json").read_text())["claims"]
    (claim,) = [c for c in claims if c["id"] == claim_id]
    return 100 * claim[field]


def _decided_per_10(folder: str) -> float:
    """Claims a reference run decided per 10 CPU-hours (`book.report.decision_rate`), the run
    whose ledger and cost lie in `folder` of `results/reference/`."""
    decided, cpu_hours, _ = decision_rate(REFERENCE / folder)
    return 10 * decided / cpu_hours


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
    # the same benchmark on one GPU (`--device cuda --out results/bench/policies_cuda.json`)
    "policies_cuda.train_full_steps_per_s": (
        "results/bench/policies_cuda.json",
        lambda: _training("full", "steps_per_s", "policies_cuda")),
    "policies_cuda.train_full_peak_mib": (
        "results/bench/policies_cuda.json",
        lambda: _training("full", "peak_memory_mib", "policies_cuda")),
    "policies_cuda.full_1600_cached_ms": (
        "results/bench/policies_cuda.json",
        lambda: _latency("full", 1600, "step_ms_kv_cache", "policies_cuda")),
    "policies_cuda.full_1600_recompute_ms": (
        "results/bench/policies_cuda.json",
        lambda: _latency("full", 1600, "step_ms_recompute", "policies_cuda")),
    **{f"cells.{kind}.{field}": ("results/bench/cells.json",
                                 lambda kind=kind, field=field: _cell(kind, field))
       for kind in ("icrt_lipvq", "bc_transformer", "act_maniskill", "kinova_eval")
       for field in ("seed_cost_s", "floor_ratio", "first_floor_ratio")},
    "older_cost.cpu_hours": (OLDER_COST, lambda: _cost_hours("cpu", OLDER)),
    **{f"older_plan.{field}": ("results/reference/older-code/plan.json",
                               lambda field=field: _plan(field, OLDER))
       for field in ("cells", "cpu_hours", "wall_hours", "cores", "undecided")},
    "kitchen_cost.cpu_hours": (KITCHEN_COST, lambda: _cost_hours("cpu", KITCHEN)),
    "cost.cells": (COST, lambda: _cost(REFERENCE)["finished_cells"]),
    "cost.planned_cells": (COST, lambda: _cost(REFERENCE)["planned_cells"]),
    "cost.cpu_hours": (COST, lambda: _cost_hours("cpu", REFERENCE)),
    "cost.elapsed_hours": (COST, lambda: _cost_hours("elapsed", REFERENCE)),
    "cost.projected_wall_hours_at_2": (
        COST, lambda: _cost(REFERENCE)["projection"]["wall_hours_at_2"]),
    "cost.target_wall_hours": (COST, lambda: _cost(REFERENCE)["projection"]["target_wall_hours"]),
    **{f"plan.{field}": (PLAN, lambda field=field: _plan(field, REFERENCE))
       for field in ("cells", "cpu_hours", "wall_hours", "cores", "undecided", "planned")},
    **{f"{prefix}.{name}": (f"results/reference/{ledger}",
                            lambda field=field, ledger=ledger: _claims(field, ledger))
       for prefix, ledger in (("claims", "claims.json"),
                              ("older_claims", "older-code/claims.json"),
                              ("kitchen_claims", "older-code/kitchen/claims.json"))
       for name, field in (("total", "claims"), ("holds", Verdict.HOLDS),
                           ("decided", "decided"), ("do_not_hold", Verdict.DOES_NOT_HOLD),
                           ("undecided", "undecided"), ("size_excluded", "size_excluded"),
                           ("size_larger", "size_larger"), ("not_run", Verdict.NOT_RUN))},
    **{f"{prefix}.decided_per_10_cpu_hours": (f"results/reference/{folder}claims.json",
                                              lambda folder=folder: _decided_per_10(folder))
       for prefix, folder in (("claims", ""), ("kitchen_claims", "older-code/kitchen/"),
                              ("older_claims", "older-code/"))},
    **{f"claim.{claim_id}.{field}_points": (
        "results/reference/claims.json",
        lambda claim_id=claim_id, field=field: _claim_points(claim_id, field))
       for claim_id in CONCLUSION_CLAIMS for field in ("ours", "paper")},
    "design.budget_hours": ("src/icil_paper/config.py",
                            lambda: get_preset("reference").tables.stage_budget_hours),
}
"""Figure name -> (the records it comes from, a function computing it from them)."""


def figure(name: str) -> float:
    """The value of one README figure, computed from its records."""
    if name not in FIGURES:
        raise KeyError(f"unknown README figure {name!r} (known: {', '.join(FIGURES)})")
    return float(FIGURES[name][1]())


MARKED = re.compile(r"(-?\d[\d,]*(?:\.\d+)?)(\s*[^\s<]*\s*)<!-- figure: ([\w.-]+) -->")
"""A README figure: the printed number with its sign, what follows it (a unit), and its
marker."""


def printed_at(value: float, printed: str) -> str:
    """`value` printed as `printed` was: with as many decimals, or as a whole number."""
    if "." in printed:
        return f"{value:.{len(printed.split('.')[1])}f}"
    return str(int(round(value)))


def update_readme(path: Path = DOCUMENTS[0]) -> list[str]:
    """Rewrite every marked figure of `path` with its current value, printed as it was;
    returns the figures that changed."""
    text = path.read_text()
    changed = []

    def replace(m: re.Match) -> str:
        printed, between, name = m.groups()
        new = printed_at(figure(name), printed.replace(",", ""))
        if new != printed:
            changed.append(f"{name}: {printed} -> {new}")
        return f"{new}{between}<!-- figure: {name} -->"

    path.write_text(MARKED.sub(replace, text))
    return changed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.readme_figures",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--update-readme", action="store_true",
                        help="rewrite the figures of the README and CONTRIBUTING.md with their "
                             "current values")
    args = parser.parse_args(argv)
    if args.update_readme:
        for path in DOCUMENTS:
            for line in update_readme(path):
                print(f"{path.name}: {line}")
        return
    for name, (source, _) in FIGURES.items():
        print(f"{name:40s} {figure(name):12.4g}   {source}")


if __name__ == "__main__":
    main()
