"""What the book reads across the paper's results: tables loaded per source, the claims
ledger and its views (chapter 00), the reference run's bookkeeping and the presets (01).

    results = load_table(preset, "I")               # {"reference run": ..., "this build": ...}
    verdicts(preset, "I")                           # the ledger's sentences, in Markdown
    claims_figure(preset, "I")                      # the forest plot of one table's claims
    ledgers = chapter_ledgers(preset)               # {"reference run": (preset, ledger), ...}
    ledger_frame(reference_ledger(ledgers))         # chapter 00: every claim, its verdict
    ledger_frame(ledger, "undecided")               # what the undecided claims could detect
    committed_design("I")                           # {"protocol": "kitchen", "seeds": {row: n}}
    for q in QUESTIONS: q.decides, q.beside         # Sec. IV's questions, the claims answering
    run_progress()                                  # the reference run's cells, hours, projection
    looks_frame(read_record(store))                 # each look's realised seeds, rows going on
    earlier_verdicts(ledger)                        # each claim beside the earlier runs' decisions
    preset_fields(preset)                           # chapter 01: field -> value, meaning

`load_table` computes what this build's store lacks (as `icil-paper reproduce` does) and
reads the reference run's committed records without computing anything; a committed record
whose key the current code no longer computes is stale (`stale_records`). This build's
ledger is written (`results/<preset>/claims.json`) before it is read; the reference run's is
read from its committed records and never written here.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from icil_paper import verdict_words
from icil_paper.book.studies import study_keys
from icil_paper.config import PRESET_NAMES, Preset, field_docs, get_preset, task_demo_counts
from icil_paper.config_data import get_path
from icil_paper.fileio import atomic_write_json, read_json
from icil_paper.paper import (
    CLAIM_LABELS,
    TABLES,
    claims_ledger,
    run_tables,
    table_spec,
    write_ledger,
)
from icil_paper.planning.staged import as_run
from icil_paper.registry import check_name
from icil_paper.results import ResultsStore
from icil_paper.runspec import eval_key, feature_key
from icil_paper.stats import Size, Verdict
from icil_paper.tables import display
from icil_paper.tables.assemble import TableResult, assemble, unbroken
from icil_paper.tables.cells import plan
from icil_paper.tables.claims import (
    LedgerEntry,
    as_entry,
    load_ledger,
    sentence,
    sizing_effect,
    summary,
)
from icil_paper.tables.design import read_record
from icil_paper.tables.display import BUILD, REFERENCE, collapsed_markdown, source_label


def load_table(preset: Preset, table_id: str, compute: bool = True,
               progress: bool = True) -> dict[str, TableResult]:
    """{source: TableResult} of one table, the reference run's first (`run_sources`)."""
    if compute:
        run_tables(preset, [table_id], progress=progress)
    return {source: assemble(table_spec(p, table_id), ResultsStore(p.name))
            for source, p in run_sources(preset)}


def run_sources(preset: Preset) -> list[tuple[str, Preset]]:
    """[(source, its run's preset)]: the reference run's (if another preset), this build's."""
    sources = [(BUILD, as_run(preset))]
    if preset.name != REFERENCE:
        sources.insert(0, (f"{REFERENCE} run", as_run(get_preset(REFERENCE))))
    return sources


def verdicts(preset: Preset, table_id: str) -> str:
    """The claims ledger's sentences about one table, for each source, as Markdown; this
    build's collapsed in a <details> block below the reference run's."""
    parts = []
    sources = run_sources(preset)
    for source, p in sources:
        entries = [e for e in claims_ledger(p, ResultsStore(p.name)) if e.table == table_id]
        if not entries:
            continue
        part = "\n".join([f"**{source_label(source, p.name)}**\n",
                          *(f"- *{e.claim}* {sentence(e)}" for e in entries), ""])
        if source == BUILD and len(sources) > 1:
            part = collapsed_markdown(verdict_words.QUICK_RUN_OPEN.format(preset=p.name), part)
        parts.append(part)
    return "\n".join(parts)


def claims_figure(preset: Preset, table_id: str):
    """The forest plot of one table's claims in the reference run's ledger (None: no claim)."""
    p = as_run(get_preset(REFERENCE))
    entries = [e for e in claims_ledger(p, ResultsStore(p.name)) if e.table == table_id]
    if not entries:
        return None
    return forest_plot(entries, title=f"Table {table_id}'s claims, reference run: 95% "
                                      "intervals, the paper's values, the decision")


RECORD_KINDS = ("train", "eval", "features", "tokenizer", "lipschitz", "showcase")
"""The kinds of record a preset's run computes and `stale_records` checks."""


def current_keys(preset_name: str = REFERENCE) -> set[str]:
    """The keys of every record a current table cell or chapter study computes at the preset."""
    preset = as_run(get_preset(preset_name))
    keys = set()
    for p in plan([table_spec(preset, t) for t in TABLES]):
        keys.add(p.run.key())
        keys.update(eval_key(p.run, ev) for ev in p.evals.values())
        keys.update(feature_key(p.run, f) for f in p.features.values())
    return keys.union(*study_keys(preset).values())


def _stale(store: ResultsStore) -> list[dict[str, Any]]:
    keys = current_keys(store.preset)
    return [r for kind in RECORD_KINDS for r in store.records(kind)
            if r["config_hash"] not in keys]


def stale_records(preset_name: str = REFERENCE) -> list[str]:
    """"kind/name" of the records in `results/<preset>/` whose key `current_keys` lacks."""
    return sorted(f"{r['kind']}/{r['name']}" for r in _stale(ResultsStore(preset_name)))


OLDER_RECORDS = "older-code/records"
"""Under `results/<preset>/`: where `retire_stale_records` moves stale records."""


def retired_records(preset_name: str = REFERENCE) -> dict[str, int]:
    """{commit: records} that `retire_stale_records` moved out of `results/<preset>/`."""
    path = ResultsStore(preset_name).dir / OLDER_RECORDS / "made_by.json"
    return json.loads(path.read_text()) if path.exists() else {}


def retire_stale_records(preset_name: str = REFERENCE) -> dict[str, int]:
    """Move every stale record of `results/<preset>/` to `older-code/records/<kind>/`,
    counted by commit in `made_by.json`. Returns {commit: records moved}."""
    store = ResultsStore(preset_name)
    older = store.dir / OLDER_RECORDS
    moved: Counter[str] = Counter()
    for record in _stale(store):
        source = store.path_for(record["kind"], record["name"], record["config_hash"])
        target = older / record["kind"] / source.name
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(source, target)
        moved[str(record.get("git_commit") or "unknown")] += 1
    if moved:
        counts = Counter(retired_records(preset_name)) + moved
        atomic_write_json(older / "made_by.json", dict(sorted(counts.items())))
    return dict(moved)


# --------------------------------------------------------------------------- the claims ledger
def _seeds_cell(seeds: dict[str, int] | None) -> str:
    """"3 v 1" for a difference, "3 v 3 3 3" for a best of k (the claim's row first)."""
    if not seeds:
        return ""
    counts = list(seeds.values())
    return f"{counts[0]} v {' '.join(map(str, counts[1:]))}" if len(counts) > 1 else str(counts[0])


def ledger_frame(ledger: list[LedgerEntry | dict[str, Any]], part: str = "verdicts"):
    """The claims ledger as a table, in parts that each fit the book's column: "verdicts"
    (seeds, the paper, ours [95% interval], verdict, decision, size), "power" (mde, power,
    seeds needed), "undecided" (the undecided claims with what their design could detect)
    and "details" (quantity, the paper's sentence, its reference and power note)."""
    check_name("ledger part", part, ("verdicts", "power", "undecided", "details"))
    rows = []
    for e in map(as_entry, ledger):
        ours = ("" if e.ours is None else
                unbroken(f"{e.ours:+.3f} [{e.ci[0]:+.3f}, {e.ci[1]:+.3f}]"))
        mde = "" if e.mde is None else f"{e.mde:.3f}"
        if part == "verdicts":
            paper_cell = (f"{e.paper:+.3f}" if e.paper is not None
                          else "—" if e.reference_effect is None
                          else f"({e.reference_effect:+.3f})")
            rows.append({"claim": e.id, "family": e.family or "",
                         "seeds": unbroken(_seeds_cell(e.seeds)), "paper": paper_cell,
                         "ours": ours, "verdict": e.verdict,
                         "decided": (e.adjusted_verdict or ""),
                         "size": verdict_words.SIZE_SHORT.get(e.size, "")})
        elif part == "power":
            needed = e.seeds_needed
            older = {"size vs the paper": e.extra["magnitude"]} if "magnitude" in e.extra else {}
            rows.append({"claim": e.id, **older, "mde": mde,
                         "power": "" if e.power is None else f"{e.power:.0%}",
                         "seeds needed": ("" if e.verdict == Verdict.NOT_RUN else
                                          str(needed) if needed else "—")})
        elif part == "details":
            rows.append({"claim": e.id, "quantity": e.quantity, "the paper says": e.claim,
                         "read against": "" if e.paper is not None else e.reference,
                         "power note": e.power_note or ""})
        elif e.adjusted_verdict in verdict_words.UNDECIDED:
            effect = sizing_effect(e)
            rows.append({"claim": e.id, "decided": e.adjusted_verdict, "ours": ours,
                         "sized against": "" if effect is None else f"{effect:+.3f}",
                         "power": "" if e.power is None or effect is None else f"{e.power:.0%}",
                         "mde": mde, "seeds needed": e.seeds_needed if effect is not None else None,
                         "note": e.power_note or ""})
    columns = (["claim", "decided", "ours", "sized against", "power", "mde", "seeds needed",
                "note"] if part == "undecided" else None)
    return pd.DataFrame(rows, columns=columns).set_index("claim").rename_axis(None)


def ledger_views(ledger: list[LedgerEntry | dict[str, Any]], title: str = "") -> dict[str, Any]:
    """Chapter 0's views of one ledger: "forest", "counts" and each part of `ledger_frame`."""
    ledger = [as_entry(e) for e in ledger]
    return {"forest": forest_plot(ledger, title=title), "counts": summary(ledger),
            **{part: ledger_frame(ledger, part) for part in ("verdicts", "undecided", "power")}}


def row_label(entry: LedgerEntry) -> str:
    """A forest plot's row: what the claim says in a few words, its id beside it."""
    label = CLAIM_LABELS.get(entry.id)
    return f"{label}  [{entry.id}]" if label else entry.id


def forest_plot(ledger: list[LedgerEntry | dict[str, Any]], title: str = ""):
    """`tables.display.forest_plot` with each claim's `row_label`."""
    return display.forest_plot(ledger, title, label=row_label)


# --------------------------------------------------------------------------- chapter 00
Ledgers = dict[str, tuple[Preset, list]]
"""{source: (its preset, its ledger entries)}, the reference run first."""


def chapter_ledgers(preset: Preset) -> Ledgers:
    """The ledgers chapter 0 shows, by source (this build's written to its store first)."""
    ledgers = {}
    for source, p in run_sources(preset):
        store = ResultsStore(p.name)
        if p.name == preset.name:
            write_ledger(p, store)
        if (read_record(store) or {}).get("protocol") == "kitchen":
            # the kitchen run's records: its tasks are retired, its ledger kept as computed
            ledgers[f"{source} (kitchen suite, older protocol)"] = (
                p, load_ledger(store.dir / "claims.json"))
        else:
            ledgers[source] = (p, claims_ledger(p, store))
    return ledgers


def committed_design(table: str, preset_name: str = REFERENCE) -> dict[str, Any]:
    """The design the committed run of `preset_name` used for `table`, from its design
    record: {"protocol": "kitchen" or "metaworld", "seeds": {row: seeds at its last look}}."""
    record = read_record(ResultsStore(preset_name)) or {}
    seeds: dict[str, int] = {}
    for look in record.get("looks", []):
        for name, n in look.get("rows", {}).items():
            t, row = name.split(":", 1)
            if t == table:
                seeds[row] = max(seeds.get(row, 0), int(n))
    return {"protocol": record.get("protocol", "metaworld"), "seeds": seeds}


def reference_ledger(ledgers: Ledgers) -> list:
    """The reference run's entries among `chapter_ledgers`' sources."""
    return next(ledger for p, ledger in ledgers.values() if p.name == REFERENCE)


@dataclass(frozen=True)
class Question:
    """One of Sec. IV's questions and the claims of the ledger that answer it."""

    key: str
    """"Q1", "Q2" or "Q3", as the paper numbers them."""
    text: str
    """The question in plain words."""
    decides: tuple[str, ...]
    """The claims whose verdicts answer it."""
    beside: tuple[str, ...] = ()
    """Claims quoted beside them (they do not change the answer)."""


QUESTIONS = (
    Question("Q1", "Does the action tokenizer matter, and is LipVQ-VAE the best one?",
             ("I-lipvq-best", "II-lipvq-best", "I-tokenizer-gap"), ("I-lipvq-vs-bc",)),
    Question("Q2", "Does smoothness explain it?",
             ("III-lipvq-smoothest", "III-smoother-succeeds", "IV-vq")),
    Question("Q3", "Does it transfer from simulation to the real robot, across data sets and "
             "to unseen tasks?",
             ("V-lipvq-vs-bc", "V-lipvq-vs-bin"), ("VI-lipvq-best", "VII-lipvq-vs-bc")),
)
"""Sec. IV's Q1-Q3 (Q3 is sim-to-real in the paper; Tables VI and VII are quoted beside)."""


def question_answers(ledger: list) -> dict[str, dict[str, Any]]:
    """For each of `QUESTIONS`, what the introduction quotes from the ledger: the first claim
    that answers it, its number and the paper's (success in points, least energy as it is)
    and the outcome in the design's words, with the seeds that would decide it if undecided."""
    words = verdict_words
    by_id = {e.id: e for e in ledger}
    out = {}
    for q in QUESTIONS:
        e = by_id[q.decides[0]]
        scale = 100 if e.table != "III" else 1
        outcome = (words.SMALLER_THAN_PAPER if e.size == Size.SMALLER
                   else words.DESIGN_OUTCOME[Verdict(e.adjusted_verdict)])
        why = words.ALONE_BUT_NOT_TOGETHER.get(e.verdict) if outcome == "undecided" else None
        needs = e.seeds_needed if e.adjusted_verdict in words.UNDECIDED else None
        if needs and needs <= min((e.seeds or {}).values(), default=0):
            needs = None  # the seeds for the paper's effect are there: the run's effect differs
        parts = [outcome, why, words.SEEDS_TO_DECIDE.format(n=needs) if needs else None]
        out[q.key] = {"ours": round(e.ours * scale, 1) if e.ours is not None else "n/a",
                      "paper": round(e.paper * scale, 1),
                      "outcome": "; ".join(p for p in parts if p)}
    return out


def seeds_range(tables: Sequence[str] = ("I", "II", "III", "V"),
                preset_name: str = REFERENCE) -> str:
    """The seeds a row the committed run's design reached in `tables`: "5", "5 to 15", or
    "no look yet"."""
    seeds = [n for t in tables for n in committed_design(t, preset_name)["seeds"].values()]
    if not seeds:
        return "no look yet"
    return f"{min(seeds)}" if min(seeds) == max(seeds) else f"{min(seeds)} to {max(seeds)}"


# --------------------------------------------------------------------------- the reference run
OLDER_LEDGER = "older-code/claims.json"
"""Under `results/reference/`: the reference ledger an older version of the code computed."""
OLDER_COST = "older-code/cost.json"
"""Under `results/<preset>/`: what the older protocol's run cost (its `cost.json`)."""


@dataclass(frozen=True)
class EarlierRun:
    """A reference run before the one on Meta-World, kept under `results/reference/`."""

    name: str
    """How the book names it."""
    folder: str
    """Its folder under `results/reference/`: its `claims.json` and `cost.json`."""


EARLIER_RUNS = (EarlierRun("the kitchen run", "older-code/kitchen"),
                EarlierRun("the older protocol's run", "older-code"))
"""The earlier reference runs, newest first."""


def reference_freshness(preset_name: str = REFERENCE) -> dict[str, int]:
    """{"records", "current", "stale"}: committed records of `preset_name` by freshness."""
    stale = len(stale_records(preset_name))
    store = ResultsStore(preset_name)
    total = sum(1 for kind in RECORD_KINDS for _ in store.records(kind))
    return {"records": total, "current": total - stale, "stale": stale}


def older_ledger(preset_name: str = REFERENCE, folder: str = "older-code"
                 ) -> tuple[dict[str, Any], list[dict]] | None:
    """(made_by, ledger) of the `claims.json` an older version of the code computed, kept in
    `folder` of `results/<preset>/` (an `EarlierRun`'s), or None when there is none."""
    path = ResultsStore(preset_name).dir / folder / "claims.json"
    if not path.exists():
        return None
    data = json.loads(path.read_text())
    return data["made_by"], data["claims"]


def run_progress(path=None) -> dict[str, Any] | None:
    """Where the committed reference run stands, from its `cost.json` (else the older
    protocol's, `older` True): cells finished and planned, sittings, hours, projected and
    target wall hours, whether more stages may follow, the commits it ran from. None without
    a cost record."""
    older = False
    if path is None:
        store = ResultsStore(REFERENCE).dir
        path, older = ((store / "cost.json", False) if (store / "cost.json").exists()
                       else (store / OLDER_COST, True))
    path = Path(path)
    if not path.exists():
        return None
    cost = json.loads(path.read_text())
    planned = cost.get("planned_cells", 0)
    if not planned:
        return None
    projection = cost.get("projection") or {}
    stages = cost.get("stages") or {}
    looks = stages.get("looks", [])
    return {"finished": cost.get("finished_cells", 0), "planned": planned,
            "sittings": len(cost["sittings"]),
            "hours": sum(s["elapsed_s"] for s in cost["sittings"]) / 3600,
            "wall_hours": projection.get("wall_hours_at_2"),
            "target_hours": projection.get("target_wall_hours"),
            "more_stages": (len(looks) < len(stages.get("stages", []))
                            and (not looks or bool(looks[-1].get("going_on")))),
            "older": older, "file": path.name,
            "commits": sorted({c for s in cost["sittings"] for c in s.get("commits", [])})}


def plan_frame(folder: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The plan `icil-paper plan` wrote for a run's undecided claims (`folder/plan.json`): one
    row a claim (seeds now and needed, cells, CPU-hours, hours on the plan's cores, why a
    claim is not planned), and its totals: `undecided`, `planned`, `cells`, `cpu_hours`,
    `wall_hours`, `cores`."""
    plan = read_json(folder / "plan.json", "a reference run's plan",
                     "write it: icil-paper plan --preset reference", keys=("claims", "total"))
    rows = pd.DataFrame(plan["claims"]).set_index("id").rename_axis(None)
    hours = f"hours at {plan['cores']} cores"
    rows = rows.rename(columns={"seeds_now": "seeds now", "seeds_needed": "seeds needed",
                                "cpu_hours": "CPU-hours", "wall_hours": hours,
                                "why_not": "not planned because"})
    totals = {"undecided": len(rows), "planned": int(rows["planned"].sum()),
              "cells": plan["total"]["cells"], "cpu_hours": round(plan["total"]["cpu_hours"], 1),
              "wall_hours": round(plan["total"]["wall_hours"], 1), "cores": plan["cores"]}
    return rows[["verdict", "seeds now", "seeds needed", "cells", "CPU-hours", hours,
                 "not planned because"]].fillna(""), totals


def decision_rate(folder: Path) -> tuple[int, float, bool] | None:
    """(claims decided, CPU-hours, every planned cell finished) of the run whose
    `claims.json` and `cost.json` lie in `folder`; None when either is missing."""
    claims, cost_file = folder / "claims.json", folder / "cost.json"
    if not claims.exists() or not cost_file.exists():
        return None
    decided = summary(json.loads(claims.read_text())["claims"])["decided"]
    cost = json.loads(cost_file.read_text())
    planned = cost.get("planned_cells")
    finished = planned is not None and cost.get("finished_cells") == planned
    return decided, cost["total"]["cpu_s"] / 3600, finished


def earlier_verdicts(ledger: list[LedgerEntry | dict[str, Any]],
                     preset_name: str = REFERENCE):
    """Each claim's decision in `ledger` (with its size against the paper's effect) beside
    its decision in every committed `EARLIER_RUNS` ledger ("" where that run lacked it)."""
    earlier = {run.name: {e["id"]: as_entry(e).adjusted_verdict for e in older[1]}
               for run in EARLIER_RUNS
               if (older := older_ledger(preset_name, run.folder)) is not None}
    rows = []
    for e in map(as_entry, ledger):
        size = (f", {verdict_words.SIZE_SHORT[e.size]} than the paper's"
                if e.size in (Size.SMALLER, Size.LARGER) else "")
        rows.append({"claim": e.id, "this run": e.adjusted_verdict + size,
                     **{name: verdicts.get(e.id, "") for name, verdicts in earlier.items()}})
    return pd.DataFrame(rows).set_index("claim").rename_axis(None)


def looks_frame(record: dict[str, Any] | None):
    """Each look of a staged run's design record (`design.json`): the seeds a row at the
    look, the rows it read with their realised seeds, the rows that went on and to how many
    seeds, and the claims the budget stopped."""
    rows = []
    record = record or {}
    for look in record.get("looks", []):
        seeds = sorted(set(look.get("rows", {}).values()))
        going = look.get("going_on") or {}
        rows.append({"look at": f"{look['seeds']} seeds", "rows read": len(look.get("rows", {})),
                     "their seeds": "–".join(map(str, seeds[::max(len(seeds) - 1, 1)])),
                     "rows going on": ", ".join(going) or "none",
                     "to seeds": ", ".join(sorted({str(n) for n in going.values()})),
                     "stopped by the budget": ", ".join(look.get("over_budget", []))})
    return pd.DataFrame(rows, columns=["look at", "rows read", "their seeds", "rows going on",
                                       "to seeds", "stopped by the budget"])


def answering_ledger(path=None) -> tuple[list, dict[str, Any] | None]:
    """(ledger, made_by) that answers the paper's questions: the committed reference
    ledger, or while none of its claims has run, `older_ledger`'s with its `made_by`."""
    path = Path(path) if path else ResultsStore(REFERENCE).dir / "claims.json"
    ledger = load_ledger(path) if path.exists() else []
    older = None if any(e.run for e in ledger) else older_ledger(REFERENCE)
    return (ledger, None) if older is None else ([as_entry(e) for e in older[1]], older[0])


PRESET_ROLES = {"smoke": "the test suite (every path runs; numbers mean nothing)",
                "small": "CI and a laptop (numbers test the code, not the paper)",
                "reference": "numbers worth reading (committed under `results/reference/`)",
                "full": "the paper's scale: GPUs or a Ray cluster"}


def preset_table() -> str:
    """The presets' scale as a Markdown table, read from the presets themselves."""
    lines = ["| preset | meant for | training steps | demonstrations per task | episodes "
             "per task | training seeds (ICRT / other rows) |", "|---|---|---|---|---|---|"]
    for name in PRESET_NAMES:
        p = get_preset(name)
        demos = str(p.data.demos_per_task)
        if p.data.task_demos:  # the tasks with counts of their own
            demos += " (" + ", ".join(f"{t.split('/', 1)[-1]}: {n}" for t, n in
                                      task_demo_counts(p.data.task_demos).items()) + ")"
        lines.append(f"| `{name}` | {PRESET_ROLES.get(name, '')} | {p.train.steps} | "
                     f"{demos} | {_preset_episodes(p)} | {_preset_seeds(p)} |")
    return "\n".join(lines)


def _preset_episodes(p: Preset) -> str:
    """"5", or a suite's own count beside the default: "metaworld: 20, ..., others: 5"."""
    by_suite = p.tables.episodes_by_suite()
    if not by_suite:
        return str(p.eval.episodes_per_task)
    return ", ".join([*(f"{suite}: {n}" for suite, n in by_suite.items()),
                      f"others: {p.eval.episodes_per_task}"])


def _preset_seeds(p: Preset) -> str:
    """"10 / 3" (ICRT / other rows), or a staged design's seeds at its looks."""
    stages = p.tables.seed_stages
    if stages:
        return f"{', '.join(map(str, stages[:-1]))} or {stages[-1]}, in stages"
    return f"{p.tables.icrt_seeds} / {p.tables.baseline_seeds}"


# --------------------------------------------------------------------------- chapter 01
PRESET_SECTIONS = ("data", "train", "eval", "tables", "tokenizer_study", "policies.icrt",
                   "tokenizers.lipvq")
"""The parts of a preset chapter 01 lists."""


def config_fields(config: Any, path: str) -> Iterator[tuple[str, Any, str]]:
    """(dotted path, value, docstring) of every leaf field of a config dataclass."""
    docs = field_docs(type(config))
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            yield from config_fields(value, f"{path}.{f.name}")
        else:
            yield f"{path}.{f.name}", value, docs.get(f.name, "")


def preset_fields(preset: Preset, sections: Sequence[str] = PRESET_SECTIONS) -> pd.DataFrame:
    """One row per leaf field of `sections`: value and docstring, indexed by its `--set` path."""
    rows = []
    for section in sections:
        rows += [{"field": name, "value": str(value), "meaning": doc}
                 for name, value, doc in config_fields(get_path(preset, section), section)]
    return pd.DataFrame(rows).set_index("field")
