"""`icil-paper plan`: what it takes to decide every claim the ledger left undecided.

    icil-paper plan --preset reference --cores 64

Every row an undecided claim of `results/<preset>/claims.json` reads gets the claim's
`seeds_needed` as one `--set tables.row_seeds=...` override; the cells the store lacks under
it are priced at the CPU time their kind took in the run (`cost.json`). Wall time at N cores
is the CPU time over N, never less than the costliest cell. It prints one line per claim,
the total and the command that runs exactly the missing cells, and writes
`results/<preset>/plan.json`.
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

from icil_paper.commands import Parser, add_preset_arguments, positive, preset_from_args
from icil_paper.config import Preset
from icil_paper.fileio import UnreadableFileError, atomic_write_json, read_json
from icil_paper.paper import TABLES, table_spec
from icil_paper.planning.cost import train_cpu_per_cell
from icil_paper.planning.design import cell_kind, claim_rows, planned_seeds, row_units
from icil_paper.planning.staged import as_run
from icil_paper.results import ResultsStore
from icil_paper.seeding import DATA_SETS
from icil_paper.tables.cells import plan, plan_records
from icil_paper.verdict_words import DECIDED

SHARES_TABLE_I = ("III", "IV", "V", "VI", "prompt")
"""Tables whose rows are Table I's runs: their seeds are Table I's row seeds."""
PLAN_FILE = "plan.json"
DEFAULT_CORES = 64


def verdict(entry: dict[str, Any]) -> str:
    """A ledger entry's verdict after the family-wise adjustment (the one the book shows)."""
    return entry.get("adjusted_verdict") or entry["verdict"]


def seeds_entry_name(table: str, row: str) -> str:
    """The `tables.row_seeds` name of a table's row ("2^9 (the paper's 2^11)" -> "fig5:512")."""
    if table in SHARES_TABLE_I:
        return f"I:{row}"
    if table == "fig5":
        power = re.match(r"2\^(\d+)", row)
        if power is None:
            raise ValueError(f"Fig. 5's row {row!r} does not name a codebook size as 2^k")
        return f"fig5:{2 ** int(power.group(1))}"
    return f"{table}:{row}"


def row_seeds_setting(preset: Preset, wanted: dict[str, int]) -> str:
    """The `--set` value of `tables.row_seeds`: the preset's entries raised to `wanted`."""
    entries = preset.tables.seeds_by_row()
    for name, n in wanted.items():
        entries[name] = max(n, entries.get(name, 0))
    return "tables.row_seeds=" + ",".join(f"{name}={n}" for name, n in entries.items())


def _rates(cost: dict[str, Any]) -> dict[str, tuple[float, float]]:
    """Kind of cell -> (training CPU s per cell, CPU s per evaluation/features record)."""
    out = {}
    for kind, g in cost["by_kind"].items():
        if not g.get("cells"):
            continue
        others = g["records"] - g["cells"]
        out[kind] = (train_cpu_per_cell(g),
                     (g["cpu_s"] - g["train_cpu_s"]) / others if others > 0 else 0.0)
    return out


def _cell_cpu_s(kind: str, records: int, rates: dict[str, tuple[float, float]]) -> float:
    if kind not in rates:  # a kind the run never trained: the nearest of its policy
        policy = kind.split()[0]
        same = [k for k in rates if k.split()[0] == policy]
        if not same:
            raise KeyError(f"cost.json has no cell of kind {kind!r} to price it by")
        kind = max(same, key=lambda k: rates[k][0])
    train, per_record = rates[kind]
    return train + records * per_record


def make_plan(preset: Preset, ledger: list[dict[str, Any]], cost: dict[str, Any],
              cores: int = DEFAULT_CORES, max_seeds: int | None = None,
              store: Any = None) -> dict[str, Any]:
    """The plan for `ledger`'s undecided claims (module docstring) as JSON."""
    store = store or ResultsStore(preset.name)
    rows_of = claim_rows(preset)
    have = planned_seeds(preset)
    open_claims = [e for e in ledger if verdict(e) not in DECIDED]
    wanted: dict[str, int] = {}
    claims = []
    for entry in open_claims:
        rows = rows_of.get(entry["id"], ())
        needed = entry.get("seeds_needed")
        line = {"id": entry["id"], "table": entry.get("table"), "verdict": verdict(entry),
                "rows": [f"{t}:{r}" for t, r in rows],
                "seeds_now": min((have.get(r, 0) for r in rows), default=0),
                "seeds_needed": needed, "planned": False,
                "why_not": entry.get("power_note") or ("not planned: the ledger has no power "
                                                       "analysis for it" if needed is None
                                                       else None)}
        if needed is not None and max_seeds is not None and needed > max_seeds:
            line["why_not"] = (f"not planned: needs {needed} seeds a row, more than "
                               f"--max-seeds {max_seeds}")
        elif needed is not None and needed > DATA_SETS:
            line["why_not"] = (f"not planned: needs {needed} seeds a row, more than the "
                               f"{DATA_SETS} demonstration sets a preset has (one per seed)")
        if line["why_not"] is None:
            line["planned"] = True
            for table, row in rows:
                if needed > have.get((table, row), 0):
                    name = seeds_entry_name(table, row)
                    wanted[name] = max(needed, wanted.get(name, 0))
        claims.append(line)

    setting = row_seeds_setting(preset, wanted)
    bigger = preset.with_overrides([setting]) if wanted else preset
    specs = {t: table_spec(bigger, t) for t in TABLES}
    rates = _rates(cost)
    missing: dict[str, float] = {}
    for p in plan(list(specs.values())):
        absent = [i for i in plan_records(p) if not store.record_path(*i).exists()]
        if absent:
            missing[p.run.key()] = _cell_cpu_s(cell_kind(p.run), len(absent) - 1, rates)
    runs_of_row: dict[tuple[str, str], dict[str, int]] = defaultdict(dict)
    for table, spec in specs.items():
        for row in spec.rows:
            runs_of_row[table, row.label].update((u.run.key(), u.seed_index)
                                                 for u in row_units(row))
    for line in claims:  # a claim alone: its rows' missing runs below its own seeds
        keys = {key for r in line["rows"] if line["planned"]
                for key, k in runs_of_row[tuple(r.split(":", 1))].items()
                if k < line["seeds_needed"] and key in missing}
        cells = [missing[k] for k in keys]
        line.update(cells=len(cells), **_hours(cells, cores))
    total = list(missing.values())
    return {"preset": preset.name, "cores": cores, "max_seeds": max_seeds,
            "set": setting if wanted else None, "claims": claims,
            "total": {"cells": len(total), **_hours(total, cores)},
            "rates_from": f"results/{preset.name}/cost.json"}


def _hours(cells: list[float], cores: int) -> dict[str, float]:
    cpu = sum(cells)
    wall = max(cpu / cores, max(cells, default=0.0))
    return {"cpu_hours": round(cpu / 3600, 2), "wall_hours": round(wall / 3600, 2)}


def format_plan(result: dict[str, Any]) -> str:
    cores = result["cores"]
    lines = [f"{'claim':38s} {'verdict':13s} {'seeds now':>9s} {'needed':>6s} {'cells':>6s} "
             f"{'CPU-h':>8s} {'h at ' + str(cores):>9s}"]
    for c in result["claims"]:
        head = f"{c['id']:38s} {c['verdict']:13s} {c['seeds_now']:9d} "
        if not c["planned"]:
            lines.append(head + f"{'-':>6s}  {c['why_not']}")
            continue
        lines.append(head + f"{c['seeds_needed']:6d} {c['cells']:6d} {c['cpu_hours']:8.1f} "
                     f"{c['wall_hours']:9.1f}")
    t = result["total"]
    lines.append(f"total (each cell once): {t['cells']} cells, {t['cpu_hours']:.1f} CPU-hours, "
                 f"{t['wall_hours']:.1f} hours at {cores} cores (one cell a core; CPU time per "
                 f"cell from {result['rates_from']})")
    if result["set"]:
        lines += ["", "run exactly the missing cells (their records, then the ledger):",
                  f"  icil-paper reproduce --preset {result['preset']} --set "
                  f"'{result['set']}' --executor ray --ray-address HEAD:6379"]
    else:
        lines.append("nothing to run: no planned claim needs more seeds")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = Parser(prog="icil-paper plan", description=__doc__.split("\n\n")[0])
    add_preset_arguments(parser)
    parser.add_argument("--cores", type=positive("--cores"), default=DEFAULT_CORES,
                        help=f"cores of the cluster, for the wall time (default {DEFAULT_CORES})")
    parser.add_argument("--max-seeds", type=positive("--max-seeds"), default=None,
                        help="leave out claims that need more seeds a row than this")
    parser.add_argument("--out", default=None, metavar="FILE",
                        help=f"where to write the plan (default results/<preset>/{PLAN_FILE})")
    args = parser.parse_args(argv)
    preset = preset_from_args(args)
    store = ResultsStore(preset.name)
    preset = as_run(preset, store)  # seeds in stages: the seeds the run reached
    inputs = {}
    for name, what, keys in (("claims.json", "a claims ledger", ("claims",)),
                             ("cost.json", "a run's cost", ("by_kind",))):
        path = store.dir / name
        fix = (f"run `icil-paper reproduce --preset {preset.name}` first (its claims stage "
               "writes claims.json; `python -m icil_paper.planning.cost` writes cost.json)")
        try:
            inputs[name] = read_json(path, what, fix, keys=keys)
        except FileNotFoundError:
            print(f"icil-paper plan: {path} is missing; {fix}", file=sys.stderr)
            return 2
        except UnreadableFileError as exc:
            print(f"icil-paper plan: {exc}", file=sys.stderr)
            return 2
    result = make_plan(preset, inputs["claims.json"]["claims"], inputs["cost.json"],
                       cores=args.cores, max_seeds=args.max_seeds, store=store)
    out = Path(args.out) if args.out else store.dir / PLAN_FILE
    print(format_plan(result))
    atomic_write_json(out, result)
    print(f"plan written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
