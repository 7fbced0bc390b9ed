"""The reference run's design: seeds per row from the claims' power, episodes per task, the
stage rule, and what the run costs.

    python -m icil_paper.planning.design             # the arithmetic behind the reference preset
    design_problems(preset, ledger)                  # rows with fewer seeds than the rule asks
    python -m icil_paper.planning.design --interim   # the rule against the seeds finished so far
    python -m icil_paper.planning.design --stages    # each claim's look, the rows that go on

**The rule.** A claim is *decidable* when its `seeds_needed` is at most `DECIDABLE_SEEDS`;
every row a decidable claim reads gets at least `DECIDABLE_SEEDS` training seeds, every
other row a claim reads at least `OTHER_SEEDS`.

**Episodes** (`episode_design`). With S seeds of E episodes per task a paired difference has
variance (seed_by_row + episode / E) / S and costs S (train + E episode);
`stats.episodes_per_seed` gives the E narrowest for its compute.

**Cost.** Optimizer steps at the measured step time plus episodes at the measured simulator
rate (`results/bench/cells.json`).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter, defaultdict
from dataclasses import replace
from pathlib import Path
from typing import Any

from icil_paper import stats
from icil_paper.commands import add_preset_arguments, preset_from_args, run_module
from icil_paper.config import Preset
from icil_paper.fileio import read_json
from icil_paper.paper import TABLES, claims, claims_ledger, table_spec
from icil_paper.records import eval_record, features_record
from icil_paper.results import ResultsStore, bench_path, results_root
from icil_paper.tables.assemble import assemble
from icil_paper.tables.cells import data_needs, plan
from icil_paper.tables.claims import Comparison, as_entry, read_ledger, sizing_effect

DECIDABLE_SEEDS = 10
"""Seeds of every row of a claim whose `seeds_needed` is at most this."""
OTHER_SEEDS = 5
"""Seeds of every other row a claim reads."""

TABLE_IDS = tuple(TABLES)
"""Every table the reference run computes."""


def row_units(row) -> list:
    """Every unit (one run and what it evaluates) of a table row's entries."""
    return [u for entry in row.entries.values() for u in entry.units]


def planned_seeds(preset: Preset) -> dict[tuple[str, str], int]:
    """(table, row) -> the training seeds the preset gives that row."""
    return {(table_id, row.label): len({u.seed_index for u in row_units(row)})
            for table_id in TABLE_IDS for row in table_spec(preset, table_id).rows}


def finished_seeds(preset: Preset, store=None) -> dict[tuple[str, str], int]:
    """(table, row) -> how many of the row's training seeds have every record its cells read."""
    store = store or ResultsStore(preset.name)
    out = {}
    for table_id in TABLE_IDS:
        for row in table_spec(preset, table_id).rows:
            whole: dict[int, bool] = {}
            for u in row_units(row):
                record = (eval_record(u.run, u.eval) if u.eval is not None
                          else features_record(u.run, u.features))
                done = store.record_path(*record).exists()
                whole[u.seed_index] = whole.get(u.seed_index, True) and done
            out[table_id, row.label] = sum(whole.values())
    return out


def claim_rows(preset: Preset) -> dict[str, tuple[tuple[str, str], ...]]:
    """Claim id -> the (table, row) pairs it reads."""
    return {c.id: tuple((c.compare.table, row) for row in c.compare.rows)
            for c in claims(preset)}


def required_seeds(entry: dict[str, Any]) -> int:
    """The seeds the rule asks of every row of a ledger entry."""
    needed = entry.get("seeds_needed")
    return DECIDABLE_SEEDS if needed is not None and needed <= DECIDABLE_SEEDS else OTHER_SEEDS


def design_ledger(preset: Preset, root: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """Claim id -> the ledger entry the design reads: of the preset's ledger and the older
    code's (`older-code/claims.json`), the one with a power analysis on the most seeds (`n`)."""
    folder = Path(root or results_root()) / preset.name
    ledgers = []
    for path, older in ((folder / "claims.json", False),
                        (folder / "older-code" / "claims.json", True)):
        if path.exists():
            ledgers.append({e["id"]: {**e, "older": older}
                            for e in read_ledger(path)["claims"]})
    out = {}
    for claim_id in claim_rows(preset):
        entries = [ledger[claim_id] for ledger in ledgers if claim_id in ledger]
        planned = [e for e in entries if e.get("seeds_needed") is not None
                   or e.get("mde") is not None]
        planned.sort(key=lambda e: -(e.get("n") or 0))  # stable: the current ledger on ties
        out[claim_id] = (planned or entries or [{"id": claim_id}])[0]
    return out


def design_problems(preset: Preset, ledger: dict[str, dict[str, Any]]) -> list[str]:
    """Rows with fewer seeds than the rule asks for `ledger` (claim id -> entry), one line each."""
    seeds = planned_seeds(preset)
    out = []
    for claim_id, rows in claim_rows(preset).items():
        want = required_seeds(ledger.get(claim_id, {}))
        for table, row in rows:
            have = seeds.get((table, row))
            if have is not None and have < want:
                out.append(f"{claim_id}: table {table} row {row} has {have} seeds, the rule "
                           f"asks {want} (seeds_needed "
                           f"{ledger.get(claim_id, {}).get('seeds_needed')})")
    return out


def expected_half_width(entry: dict[str, Any], seeds: int) -> float | None:
    """The 95% half-width a claim's difference is expected to have at `seeds` seeds a row,
    from the entry's `plan` variance, else (an older ledger, Welch's test) the variance read
    back from its `mde` or its `seeds_needed`; None below two seeds or with neither."""
    plan, mde, rows = entry.get("plan"), entry.get("mde"), entry.get("seeds") or {}
    needed, effect = entry.get("seeds_needed"), sizing_effect(entry)
    if seeds < 2:
        return None
    if plan:
        var, paired = plan["variance"], plan["paired"]
    elif mde is not None and min(rows.values(), default=0) >= 2:
        var, paired = (mde / stats.minimum_detectable(1.0, min(rows.values()), paired=False)) ** 2, False
    elif needed and effect:
        var, paired = (effect / stats.minimum_detectable(1.0, needed, paired=False)) ** 2, False
    else:
        return None
    df = seeds - 1 if paired else 2 * seeds - 2
    return float(stats.repeated_interval(0.0, math.sqrt(var / seeds), df, stats.ALPHA)[1])


# --------------------------------------------------------------------------- cost
def cell_kind(run) -> str:
    """A run's kind of cell: policy, suite and observations ("icrt kitchen state")."""
    suite = run.data.tasks[0].split("/", 1)[0]
    return f"{run.policy.type} {suite} {run.data.obs}"


def cell_rates(path: str | Path | None = None) -> dict[str, Any]:
    """Measured rates from `results/bench/cells.json` (step seconds, env step rates)."""
    record = read_json(Path(path or bench_path("cells")), "a cell benchmark (cells.json)",
                       "measure it again: make bench (or restore it from git)", keys=("cells",),
                       fields={"cells": list})
    step_s, env_rate, steps_per_episode = {}, {}, {}
    for cell in record["cells"]:
        steady = cell["steady"]
        policy = cell["run"].split("+")[0]
        if steady.get("step_ms"):
            step_s.setdefault(policy, steady["step_ms"] / 1000)
        suite = "kinova" if cell["kind"] == "kinova_eval" else cell["tasks"][0].split("/")[0]
        sim = steady["phases_s"].get("eval.sim")
        if sim and steady["episodes"]:
            env_rate.setdefault(suite, steady["env_steps"] / sim)
            steps_per_episode.setdefault(suite, steady["env_steps"] / steady["episodes"])
    return {"step_s": step_s, "env_steps_per_s": env_rate,
            "env_steps_per_episode": steps_per_episode}


IMAGE_SLOWDOWN = 10.0
"""Image rollouts and training cost about ten times their state counterparts on CPU."""


def plan_cost(preset: Preset, rates: dict[str, Any] | None = None) -> dict[str, Any]:
    """The estimated cost of every run the preset's tables plan, by kind of cell."""
    return plans_cost(plan([table_spec(preset, t) for t in TABLE_IDS]), rates)


def plans_cost(plans, rates: dict[str, Any] | None = None) -> dict[str, Any]:
    """`plan_cost` of a list of run plans (`tables.cells.plan`), their data sets included."""
    rates = rates or cell_rates()
    kinds: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    for p in plans:
        k = kinds[cell_kind(p.run)]
        images = IMAGE_SLOWDOWN if p.run.data.obs != "state" else 1.0
        step_s = rates["step_s"].get(p.run.policy.type, rates["step_s"]["act"])
        k["cells"] += 1
        k["train_steps"] += p.run.train.steps
        k["train_s"] += p.run.train.steps * step_s * images
        for ev in p.evals.values():
            suite = ev.task.split("/", 1)[0]
            steps = rates["env_steps_per_episode"].get(suite, 200.0)
            if ev.max_steps:
                steps = min(steps, ev.max_steps)
            k["episodes"] += ev.episodes
            k["eval_s"] += ev.episodes * steps / rates["env_steps_per_s"].get(suite, 150.0) * images
    data = data_cost(plans)
    total = sum(k["train_s"] + k["eval_s"] for k in kinds.values()) + data["core_s"]
    return {"kinds": {name: {f: round(v, 1) for f, v in k.items()} for name, k in kinds.items()},
            "data": data, "cells": len(plans), "core_s": round(total, 1),
            "wall_h_at_2": round(total / 2 / 3600, 2)}


def data_cost(plans, path: str | Path | None = None) -> dict[str, Any]:
    """What generating the plans' demonstration sets costs (`results/bench/datasets.json`)."""
    source = Path(path or bench_path("datasets"))
    measured = (read_json(source, "the data-set generation benchmark (datasets.json)",
                          "regenerate it: python -m tools.bench.datasets",
                          keys=("suites",), fields={"suites": dict})
                if source.exists() else {"suites": {}})
    rates = {suite: m["cpu_s_per_demo"] for suite, m in measured["suites"].items()}
    needs = data_needs(plans)
    demos = sum(needs.values())
    core = sum(n * rates.get(task.split("/", 1)[0], 0.0)
               * (IMAGE_SLOWDOWN if obs != "state" else 1.0)
               for (task, _, obs, _), n in needs.items())
    sets = {seed for (_, _, _, seed) in needs}
    return {"data_sets": len(needs), "demonstration_sets": len(sets), "demos": demos,
            "core_s": round(core, 1), "measured": sorted(rates)}


def _claims_report(preset: Preset, ledger: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Every claim's rows and seeds, required seeds and half-width now and expected."""
    seeds = planned_seeds(preset)
    claims_out = []
    for claim_id, rows in claim_rows(preset).items():
        entry = ledger[claim_id]
        planned = min((seeds.get(r, 0) for r in rows), default=0)
        hw = expected_half_width(entry, planned)
        claims_out.append({
            "id": claim_id, "rows": {f"{t}:{r}": seeds.get((t, r)) for t, r in rows},
            "seeds_needed": entry.get("seeds_needed"), "required": required_seeds(entry),
            "paper": sizing_effect(entry),
            "half_width_now": (None if not entry.get("ci") else
                               round((entry["ci"][1] - entry["ci"][0]) / 2, 4)),
            "expected_half_width": None if hw is None else round(hw, 4)})
    return claims_out


def design_frame(preset: Preset):
    """The design's claims as a table for the book: seeds needed and where the variances came
    from, required, planned and finished seeds, the expected 95% half-width. A staged preset
    (pass `staged.as_run`'s) shows its stage's seeds instead of required and planned."""
    import pandas as pd

    ledger = design_ledger(preset)
    finished = finished_seeds(preset)
    rows = claim_rows(preset)
    staged = bool(preset.tables.seed_stages)
    lines = []
    for c in _claims_report(preset, ledger):
        entry = ledger[c["id"]]
        planned_from = entry.get("seeds_needed") is not None or entry.get("mde") is not None
        source = ("no power analysis" if not planned_from else
                  f"{entry['n']} seeds" + (" (older code)" if entry.get("older") else ""))
        seeds = ({"stage": min(c["rows"].values())} if staged else
                 {"required": c["required"], "planned": min(c["rows"].values())})
        lines.append({"claim": c["id"], "seeds needed": c["seeds_needed"] or "—",
                      "from": source, **seeds,
                      "finished": min(finished[r] for r in rows[c["id"]]),
                      "expected ±": ("" if c["expected_half_width"] is None
                                     else f"{c['expected_half_width']:.3f}")})
    return pd.DataFrame(lines).set_index("claim").rename_axis(None)


def with_row_seeds(preset: Preset, seeds: dict[tuple[str, str], int]) -> Preset:
    """`preset` with the rows of `seeds` at those seeds (appended to `row_seeds`, so they win)."""
    entries = tuple(f"{t}:{row}={n}" for (t, row), n in sorted(seeds.items()))
    tables = replace(preset.tables, row_seeds=preset.tables.row_seeds + entries)
    return replace(preset, tables=tables)


def at_seeds(preset: Preset, seeds: int) -> Preset:
    """The preset with every row of every table at its first `seeds` training seeds."""
    tables = replace(preset.tables, icrt_seeds=seeds, baseline_seeds=seeds,
                     since_paper_seeds=seeds, official_seeds=seeds,
                     row_seeds=tuple(f"{t}:*={seeds}" for t in TABLE_IDS))
    return replace(preset, tables=tables)


def interim_ledger(preset: Preset, seeds: int | None = None, store=None
                   ) -> tuple[int, list[dict[str, Any]] | None]:
    """(seeds, the ledger of every row's first `seeds` seeds), default the most every
    claim's rows have finished; the ledger is None below two seeds."""
    store = store or ResultsStore(preset.name)
    if seeds is None:
        finished = finished_seeds(preset, store)
        seeds = min(finished[r] for rows in claim_rows(preset).values() for r in rows)
    if seeds < 2:
        return seeds, None
    return seeds, claims_ledger(at_seeds(preset, seeds), store)


# --------------------------------------------------------------------------- stages
def stage_plan(preset: Preset, ledger: list[dict[str, Any]],
               budget_hours: float | None = None) -> dict[str, Any]:
    """The stage rule on a ledger computed with the preset's `seed_stages`: a row goes on
    when a claim that reads it has a `sequential["next"]` (undecided, with enough
    conditional power) and, with `budget_hours`, fits the budget (`within_budget`).

    Returns {"continue": {(table, row): (next seeds, [claim ids])}, "stop": {(table, row):
    [claim ids]}, "over_budget": {claim id: next seeds}}."""
    by_id = {e.id: e for e in map(as_entry, ledger)}
    rows_of = claim_rows(preset)
    wanted = {claim_id: nxt for claim_id in rows_of
              if (nxt := (getattr(by_id.get(claim_id), "sequential", None) or {}).get("next"))}
    readers = {row for rows in rows_of.values() for row in rows}
    runs = {row: _first_runs(preset, *row) for row in readers}
    over: dict[str, int] = {}
    if budget_hours is not None and wanted:
        wanted, over = within_budget(preset, wanted, budget_hours, runs=runs)
    go = _going_rows(runs, rows_of, wanted)
    return {"continue": go,
            "stop": {row: [c for c, rows in rows_of.items() if row in rows]
                     for row in sorted(readers) if row not in go},
            "over_budget": over}


def _going_rows(runs: dict[tuple[str, str], frozenset[str]],
                rows_of: dict[str, tuple[tuple[str, str], ...]], going: dict[str, int]
                ) -> dict[tuple[str, str], tuple[int, list[str]]]:
    """{row: (next seeds, [claim ids])} of the claims `going` on ({claim id: next seeds})
    and the rows sharing their runs."""
    go: dict[tuple[str, str], tuple[int, list[str]]] = {}
    for claim_id, nxt in going.items():
        for row in rows_of[claim_id]:
            seeds, ids = go.get(row, (0, []))
            go[row] = (max(seeds, nxt), [*ids, claim_id])
    direct = dict(go)
    for row in sorted(runs):
        if row in go:
            continue
        shared = [(other, direct[other]) for other in direct if runs[row] & runs[other]]
        if shared:
            go[row] = (max(s for _, (s, _) in shared),
                       [f"runs of {t}:{r}" for (t, r), _ in shared])
    return go


def within_budget(preset: Preset, wanted: dict[str, int], budget_hours: float,
                  rates: dict[str, Any] | None = None,
                  runs: dict[tuple[str, str], frozenset[str]] | None = None,
                  ) -> tuple[dict[str, int], dict[str, int]]:
    """Split `wanted` ({claim id: next seeds}) into (going on, stopped by the budget): claims
    are taken cheapest next stage first while the plan stays within `budget_hours` (at two
    cells at a time). Prices come from the committed benchmark rates, so the same records
    give the same stages on any machine."""
    rows_of = claim_rows(preset)
    rates = rates or cell_rates()
    if runs is None:
        runs = {row: _first_runs(preset, *row) for rows in rows_of.values() for row in rows}
    # Every claim going on at once plans every run any subset of them can add.
    upper = with_row_seeds(preset, {row: n for row, (n, _) in
                                    _going_rows(runs, rows_of, wanted).items()})
    specs = {t: table_spec(upper, t) for t in TABLE_IDS}
    plans = {p.run.key(): p for p in plan(list(specs.values()))}
    now = {p.run.key() for p in plan([table_spec(preset, t) for t in TABLE_IDS])}
    units = {(t, r): [(u.seed_index, u.run.key()) for u in row_units(specs[t].row(r))]
             for t, r in runs}

    def hours(claims: dict[str, int]) -> float:
        keys = set(now)
        for row, (n, _) in _going_rows(runs, rows_of, claims).items():
            keys |= {key for seed, key in units[row] if seed < n}
        return plans_cost([plans[k] for k in keys], rates)["core_s"] / 2 / 3600

    base = hours({})
    price = {c: hours({c: n}) - base for c, n in wanted.items()}
    taken: dict[str, int] = {}
    for claim_id in sorted(wanted, key=lambda c: (price[c], list(wanted).index(c))):
        trial = {**taken, claim_id: wanted[claim_id]}
        if hours(trial) <= budget_hours:
            taken = trial
    return taken, {c: n for c, n in wanted.items() if c not in taken}


def _first_runs(preset: Preset, table: str, row: str) -> frozenset[str]:
    """The keys of a row's first training seed's runs."""
    return frozenset(u.run.key() for u in row_units(table_spec(preset, table).row(row))
                     if u.seed_index == 0)


def stage_counts(ledger: list[dict[str, Any]]) -> dict[str, Any]:
    """What a staged ledger decided at each look: {"claims", "decided", "decided_at" ({seeds:
    claims}), "going" (ids), "stopped", "by_budget", "unlooked"}."""
    seq = [(e.id, e.sequential) for e in map(as_entry, ledger)
           if getattr(e, "sequential", None)]
    unlooked = sum(1 for _, s in seq if not s["looks"])
    decided = Counter(s["decided_at"] for _, s in seq if s["decided_at"] is not None)
    going = [claim_id for claim_id, s in seq if s["next"]]
    return {"claims": len(ledger), "decided": sum(decided.values()),
            "decided_at": dict(sorted(decided.items())), "going": going,
            "stopped": len(seq) - sum(decided.values()) - len(going) - unlooked,
            "by_budget": sum(1 for _, s in seq if s.get("stopped_by") == "budget"),
            "unlooked": unlooked}


# --------------------------------------------------------------------------- episodes
def episode_design(preset: Preset, store=None, cost: dict[str, Any] | None = None
                   ) -> list[dict[str, Any]]:
    """Per suite and class of claim (tokenizer pairs, policy pairs, all pairs): the episode
    and seed-by-row parts of the paired variance (`stats.paired_variance_parts`) and the
    cost-optimal episodes per task at the run's CPU times (`cost.json`)."""
    store = store or ResultsStore(preset.name)
    cost = cost if cost is not None else read_json(
        Path(store.dir) / "cost.json", "a run's cost (cost.json)",
        "write it: python -m icil_paper.planning.cost", keys=("by_kind",))
    tables: dict[str, Any] = {}
    parts: dict[tuple[str, str], list] = defaultdict(list)
    for claim in claims(preset):
        compare = claim.compare
        if not isinstance(compare, Comparison) or compare.kind != "success":
            continue
        if compare.table not in tables:
            tables[compare.table] = assemble(table_spec(preset, compare.table), store)
        result = tables[compare.table]
        if compare.scenes(tables) != "per_seed" or compare.data(tables) is None:
            continue
        spec = result.spec.row(compare.a).entries[compare.column].units[0]
        for other in compare.others:
            a, b = result.outcomes(compare.a, compare.column), result.outcomes(other, compare.column)
            if min(len(a), len(b)) < 2 or a.shape[2] < 2:
                continue
            pair = ("tokenizer pairs" if result.spec.row(other).entries[compare.column].units[0]
                    .run.policy.type == spec.run.policy.type else "policy pairs")
            suite = spec.eval.task.split("/", 1)[0] if spec.eval else "?"
            parts[suite, pair].append((*stats.paired_variance_parts(a, b), a.shape[1],
                                       a.shape[2], cell_kind(spec.run)))
    rates = {kind: (g["train_cpu_s"] / g["cells"], (g["cpu_s"] - g["train_cpu_s"]) / g["cells"])
             for kind, g in cost["by_kind"].items() if g.get("cells") and g.get("episodes")}
    for (suite, _), values in list(parts.items()):
        parts[suite, "all pairs"] += values  # the suite's count: every comparison alike
    out = []
    for (suite, pair), values in sorted(parts.items()):
        episode, seed_by_row = (sum(v[i] for v in values) / len(values) for i in (0, 1))
        episodes, kind = values[0][3], values[0][4]
        train, evaluations = rates.get(kind, (None, None))
        best = (None if not train or seed_by_row <= 0 else stats.episodes_per_seed(
            seed_by_row, episode, train, evaluations / episodes))
        out.append({"suite": suite, "pairs": pair, "comparisons": len(values),
                    "episodes_now": episodes, "episode_part": episode,
                    "seed_by_row_part": seed_by_row,
                    "episode_share": episode / episodes / (episode / episodes + seed_by_row),
                    "train_cpu_s": train, "episode_cpu_s": evaluations and evaluations / episodes,
                    "optimal_episodes": best})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icil_paper.planning.design",
                                     description=__doc__.split("\n\n")[0])
    add_preset_arguments(parser)
    parser.add_argument("--interim", action="store_true",
                        help="also check the rule against a ledger of the seeds every claim's "
                             "rows have finished so far (a preview: which rows to top up)")
    parser.add_argument("--stages", action="store_true",
                        help="apply the stage rule of the preset's seed stages "
                             "(tables.seed_stages) to the ledger of its records: each claim's "
                             "look, and which rows go on to the next stage")
    args = parser.parse_args(argv)
    try:
        preset = preset_from_args(args)
    except ValueError as exc:  # a bad --set or preset name: one line, no traceback
        print(exc, file=sys.stderr)
        return 2
    if args.stages:
        return _print_stages(preset)

    ledger, cost = design_ledger(preset), plan_cost(preset)
    for c in _claims_report(preset, ledger):
        print(f"{c['id']:<38} needed {str(c['seeds_needed']):>5}  required {c['required']:>2}  "
              f"hw now {c['half_width_now']}  expected {c['expected_half_width']}  "
              f"rows {c['rows']}")
    for line in design_problems(preset, ledger):
        print("violation:", line)
    for name, k in sorted(cost["kinds"].items()):
        print(f"{name:<28} {k}")
    print(f"{cost['cells']} cells, {cost['core_s'] / 3600:.1f} core-hours, "
          f"{cost['wall_h_at_2']} h at two cells at a time")
    if args.interim:
        seeds, ledger = interim_ledger(preset)
        if ledger is None:
            print(f"interim: the claims' rows have {seeds} finished seeds in common; a "
                  "variance needs 2")
        else:
            problems = design_problems(preset, {e.id: e.to_dict() for e in ledger})
            print(f"interim, at the {seeds} seeds every claim's rows have finished: "
                  f"{len(problems)} rows below the rule")
            for e in ledger:
                print(f"  {e.id:<38} seeds needed {str(e.seeds_needed):>5}  "
                      f"verdict {e.verdict}")
            for line in problems:
                print("  top up:", line)
    return 0


def _print_stages(preset: Preset) -> int:
    if not preset.tables.seed_stages:
        print(f"preset {preset.name!r} has no seed stages: set them, e.g. "
              "--set tables.seed_stages=5,10,15", file=sys.stderr)
        return 2
    ledger = claims_ledger(preset)
    design = stats.SequentialDesign(preset.tables.seed_stages)
    print(f"looks at {', '.join(map(str, design.stages))} seeds a row; O'Brien-Fleming-type "
          "alpha spending (Lan and DeMets 1983): at a level of 5% a look decides when its "
          "t-test p-value is at most " + ", ".join(f"{p:.3g}" for p in design.nominal_levels()))
    for e in map(as_entry, ledger):
        p = (getattr(e, "sequential", None) or {}).get("p_value")
        print(f"  {e.id:<38} {str(e.adjusted_verdict):<14} design p "
              f"{'-' if p is None else f'{p:.3g}':>9}  {getattr(e, 'look', '')}")
    plan = stage_plan(preset, ledger, preset.tables.stage_budget_hours)
    for (table, row), (seeds, ids) in sorted(plan["continue"].items()):
        print(f"continue  {table}:{row} to {seeds} seeds  ({', '.join(ids)})")
    for (table, row), ids in sorted(plan["stop"].items()):
        print(f"stop      {table}:{row}  ({', '.join(ids)})")
    for claim_id, seeds in plan["over_budget"].items():
        print(f"budget    {claim_id} stops: {seeds} seeds a row are over "
              f"{preset.tables.stage_budget_hours:g} hours")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_module("python -m icil_paper.planning.design", main))
