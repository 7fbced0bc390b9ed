"""What a preset's run cost, computed from its records: `results/<preset>/cost.json`.

    python -m icil_paper.planning.cost --preset reference    # writes results/reference/cost.json

Every record carries the wall and CPU time of its computation. A record counts under the
first stage of `icil-paper reproduce` whose tables plan it and under its kind of cell
(policy, suite and observations: "icrt kitchen state"); records the current plan does not
name (older code) are counted apart.

Sittings: records whose finish times lie less than `SITTING_GAP_S` apart. Summed wall time
over a sitting's elapsed time is how many cells ran at once.

Projection: each unfinished cell at the CPU time per cell its stage and kind measured so
far (else `cells.json`'s estimate); wall time at two cells at a time is the CPU time over
two, set beside the budget (`config.REFERENCE_BUDGET_HOURS` by default).
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from datetime import datetime
from pathlib import Path
from typing import Any

from icil_paper.commands import add_preset_arguments, preset_from_args, run_module
from icil_paper.config import REFERENCE_BUDGET_HOURS, Preset
from icil_paper.fileio import atomic_write_json, read_json
from icil_paper.paper import table_spec
from icil_paper.planning.design import cell_kind, episode_design, plan_cost, planned_seeds
from icil_paper.planning.staged import as_run, at_stage, staged_preset
from icil_paper.results import ResultsStore, read_record_file
from icil_paper.stages import TABLE_STAGES
from icil_paper.tables.cells import plan, plan_records

FIELDS = ("records", "cells", "train_steps", "episodes", "wall_s", "cpu_s", "train_cpu_s",
          "resumed_cells", "resumed_cpu_s", "without_cpu_time")
"""What is summed over records, for every group. `resumed_cells` counts cells whose training
resumed from a checkpoint (their train record times only the steps after it), `resumed_cpu_s`
that training's CPU time."""

SITTING_GAP_S = 1800.0
"""Records further apart than this (half an hour) start a new sitting."""

CELLS_AT_ONCE = 2


def _planned(preset: Preset, store: ResultsStore) -> dict[Path, tuple[str, str]]:
    """Record path -> (stage, kind of cell) for every record the table stages plan."""
    out: dict[Path, tuple[str, str]] = {}
    for table_id, _, _ in TABLE_STAGES:
        for p in plan([table_spec(preset, table_id)]):
            group = (f"table-{table_id}", cell_kind(p.run))
            for record_id in plan_records(p):
                out.setdefault(store.record_path(*record_id), group)
    return out


def _add(total: dict[str, float], record: dict[str, Any]) -> None:
    total["records"] += 1
    total["wall_s"] += float(record.get("wall_time_s") or 0.0)
    total["cpu_s"] += float(record.get("cpu_time_s") or 0.0)
    total["without_cpu_time"] += "cpu_time_s" not in record
    if record["kind"] == "train":
        cpu = float(record.get("cpu_time_s") or 0.0)
        total["cells"] += 1
        total["train_steps"] += int(record["metrics"].get("steps") or 0)
        total["train_cpu_s"] += cpu
        if record["metrics"].get("resumed_from_step"):
            total["resumed_cells"] += 1
            total["resumed_cpu_s"] += cpu
    if record["kind"] == "eval":
        total["episodes"] += int(record["metrics"].get("episodes") or 0)


def _sittings(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    spans = []
    for r in records:
        end = datetime.fromisoformat(r["finished"]).timestamp()
        spans.append((end - float(r.get("wall_time_s") or 0.0), end, r))
    spans.sort(key=lambda s: s[1])
    out: list[dict[str, Any]] = []
    for start, end, r in spans:
        if out and end - out[-1]["_end"] <= SITTING_GAP_S:
            s = out[-1]
            s["_start"], s["_end"] = min(s["_start"], start), end
        else:
            s = {"_start": start, "_end": end, "records": 0, "wall_s": 0.0, "cpu_s": 0.0,
                 "commits": set()}
            out.append(s)
        s["records"] += 1
        s["wall_s"] += float(r.get("wall_time_s") or 0.0)
        s["cpu_s"] += float(r.get("cpu_time_s") or 0.0)
        s["commits"].add(r.get("git_commit", "")[:7])
    for s in out:
        elapsed = s["_end"] - s.pop("_start")
        end = s.pop("_end")
        s.update(ended=datetime.fromtimestamp(end).astimezone().isoformat(timespec="seconds"),
                 elapsed_s=round(elapsed, 1), wall_s=round(s["wall_s"], 1),
                 cpu_s=round(s["cpu_s"], 1), commits=sorted(s["commits"]),
                 cells_at_once=round(s["wall_s"] / elapsed, 2) if elapsed > 0 else None)
    return out


def _rounded(groups: dict[str, dict[str, float]]) -> dict[str, dict[str, Any]]:
    out = {}
    for name, t in sorted(groups.items()):
        out[name] = {k: (round(v, 1) if k.endswith("_s") else int(v)) for k, v in t.items()}
        measured = t["wall_s"] and not t["without_cpu_time"]
        out[name]["cpu_per_wall"] = round(t["cpu_s"] / t["wall_s"], 3) if measured else None
    return out


def run_cost(preset: Preset, store: ResultsStore | None = None) -> dict[str, Any]:
    """The cost of the preset's records (see the module docstring)."""
    store = store or ResultsStore(preset.name)
    planned = _planned(preset, store)
    def new() -> dict[str, float]:
        return defaultdict(float, dict.fromkeys(FIELDS, 0.0))
    by_stage: dict[str, dict[str, float]] = defaultdict(new)
    by_kind: dict[str, dict[str, float]] = defaultdict(new)
    by_group: dict[tuple[str, str], dict[str, float]] = defaultdict(new)
    total, older = new(), new()
    current, hosts = [], set()
    for path in sorted(store.dir.glob("*/*.json")):
        if path.name == "claims.json":
            continue
        record = read_record_file(path)
        if "kind" not in record or "wall_time_s" not in record:
            continue
        where = planned.get(path)
        if where is None and record["kind"] in ("train", "eval", "features"):
            _add(older, record)
            continue
        stage, kind = where or (record["kind"], record["kind"])
        for group in (by_stage[stage], by_kind[kind], by_group[stage, kind], total):
            _add(group, record)
        current.append(record)
        host = record.get("host") or {}
        hosts.add((host.get("cpu_count"), host.get("gpu"), host.get("platform", "")))
    seeds = planned_seeds(preset)
    return {
        "preset": preset.name,
        "total": _rounded({"all": total})["all"],
        "by_stage": _rounded(by_stage),
        "by_kind": _rounded(by_kind),
        "planned_cells": sum(1 for p, (stage, _) in planned.items()
                             if p.parent.name == "train" and stage.startswith("table-")),
        "finished_cells": int(sum(t["cells"] for stage, t in by_stage.items()
                                  if stage.startswith("table-"))),
        "planned_rows": len(seeds),
        "planned_seeds": sum(seeds.values()),
        "older_code": _rounded({"older": older})["older"],
        "machines": [{"cpu_count": c, "gpu": g, "platform": p} for c, g, p in sorted(
            hosts, key=str)],
        "sittings": _sittings(current),
        "projection": _projection(preset, planned, by_group, total["cpu_s"]),
    }


def train_cpu_per_cell(group: dict[str, float]) -> float:
    """A finished cell's mean training CPU time, averaged over the cells trained in one go
    (a resumed cell's record times only the steps after its checkpoint)."""
    whole = group["cells"] - group.get("resumed_cells", 0)
    if not whole:
        return group["train_cpu_s"] / group["cells"]
    return (group["train_cpu_s"] - group.get("resumed_cpu_s", 0.0)) / whole


def _projection(preset: Preset, planned: dict[Path, tuple[str, str]],
                by_group: dict[tuple[str, str], dict[str, float]],
                cpu_so_far: float) -> dict[str, Any]:
    """The whole run's CPU time and idle-machine wall time (see the module docstring)."""
    cells: dict[tuple[str, str], int] = defaultdict(int)
    for path, group in planned.items():
        if path.parent.name == "train":
            cells[group] += 1
    estimate = {kind: (k["train_s"] + k["eval_s"]) / k["cells"]
                for kind, k in plan_cost(preset)["kinds"].items() if k["cells"]}
    groups, remaining, from_records = {}, 0.0, 0.0
    for (stage, kind), n in sorted(cells.items()):
        done = by_group.get((stage, kind))
        finished = int(done["cells"]) if done else 0
        measured = finished and not done["without_cpu_time"]
        if measured:
            per_cell = (done["cpu_s"] - done["train_cpu_s"]) / done["cells"] + train_cpu_per_cell(done)
        else:  # the same plans, so every kind planned here has an estimate
            per_cell = estimate.get(kind)
        if per_cell is None:
            raise KeyError(f"no cost estimate for cells of kind {kind!r}: run "
                           "`python -m tools.bench.cells` to measure one")
        left = max(n - finished, 0) * per_cell
        remaining += left
        from_records += left if measured else 0.0
        groups[f"{stage} / {kind}"] = {
            "planned_cells": n, "finished_cells": finished, "cpu_s_per_cell": round(per_cell, 1),
            "rate_from": "records" if measured else "cells.json", "remaining_cpu_s": round(left, 1)}
    cpu_total = cpu_so_far + remaining
    return {
        "groups": groups,
        "remaining_cpu_hours": round(remaining / 3600, 2),
        "cpu_hours": round(cpu_total / 3600, 2),
        "wall_hours_at_2": round(cpu_total / CELLS_AT_ONCE / 3600, 2),
        "target_wall_hours": preset.tables.stage_budget_hours or REFERENCE_BUDGET_HOURS,
        "from_records": round((cpu_so_far + from_records) / cpu_total, 3) if cpu_total else None,
    }


def stages_cost(preset: Preset, store: ResultsStore) -> dict[str, Any]:
    """A staged run's looks so far and its projected wall hours (`design.plan_cost`) at the
    stage reached, at the last stage and at the fixed design's seeds, beside its budget."""
    _, looks = staged_preset(preset, store)
    return {"stages": list(preset.tables.seed_stages),
            "looks": [look.to_dict() for look in looks],
            "reached_wall_hours_at_2": plan_cost(as_run(preset, store))["wall_h_at_2"],
            "last_stage_wall_hours_at_2": plan_cost(at_stage(preset, -1))["wall_h_at_2"],
            "budget_wall_hours": preset.tables.stage_budget_hours,
            "stopped_by_budget": list(as_run(preset, store).tables.stage_stops),
            "fixed_design_wall_hours_at_2": plan_cost(preset)["wall_h_at_2"]}


def read_cost(path: str | Path) -> dict[str, Any]:
    """A run's `cost.json` (`write_cost`); a damaged one raises one line naming the fix."""
    return read_json(path, "a run's cost (cost.json)",
                     "regenerate it: python -m icil_paper.planning.cost --preset <preset>",
                     keys=("preset", "total"),
                     fields={"preset": str, "total": dict, "by_stage": dict, "by_kind": dict})


def write_cost(preset: Preset, store: ResultsStore | None = None) -> Path:
    """Write `results/<preset>/cost.json` (at the stage the run has reached); returns its path."""
    store = store or ResultsStore(preset.name)
    path = store.dir / "cost.json"
    cost = run_cost(as_run(preset, store), store)
    if preset.tables.seed_stages:
        cost["stages"] = stages_cost(preset, store)
    atomic_write_json(path, cost)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icil_paper.planning.cost",
                                     description=__doc__.split("\n\n")[0])
    add_preset_arguments(parser)
    parser.add_argument("--episodes", action="store_true",
                        help="print, instead, the seed and episode parts of each class of "
                             "claim's paired variance and the cost-optimal episodes per task "
                             "(`design.episode_design`, from the records and cost.json)")
    args = parser.parse_args(argv)
    preset = preset_from_args(args)
    if args.episodes:
        for row in episode_design(as_run(preset)):
            best = row["optimal_episodes"]
            print(f"{row['suite']:<10} {row['pairs']:<16} {row['comparisons']:>3} comparisons  "
                  f"episode part {row['episode_share']:.0%} of the variance at "
                  f"{row['episodes_now']} episodes a task; cost-optimal: "
                  f"{'-' if best is None else f'{best:.1f}'} episodes a task")
        return 0
    path = write_cost(preset)
    cost = read_cost(path)
    print(f"wrote {path}: {cost['total']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_module("python -m icil_paper.planning.cost", main))
