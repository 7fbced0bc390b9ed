"""Seeds in stages, run: the seeds of every row at the stage a preset's records have reached.

A preset with `tables.seed_stages` (the reference preset: 5, 10, 15) is not run at the seeds
its rows list. Every row a claim reads starts at the first stage's seeds; once every cell of
a stage is stored, the ledger looks (`claims_ledger`, with the group-sequential boundaries of
`stats.SequentialDesign`) and the stage rule (`design.stage_plan`) says which rows go on to
the next stage: the rows of a claim still undecided that a later stage can decide at the
paper's effect. The others stop where they are. With a budget (`tables.stage_budget_hours`,
the reference preset's twelve hours) only the claims whose next stage fits in it go on,
the cheapest first (`design.within_budget`); the claims it stops are the preset's
`tables.stage_stops`, which the ledger reads. Rows no claim reads (MCR; the analysis
table's variants) keep the seeds the preset lists.

    preset, looks = staged_preset(get_preset("reference"))   # this sitting's seeds per row
    icil-paper reproduce --preset reference                   # runs the stages in turn

The stages are a function of the stored records alone, so a run stopped in any stage and
rerun recomputes the same looks and goes on where it stopped; and the book, the cost and
the stale-record check read the same seeds per row as the run (`staged_preset`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from icil_paper.config import Preset
from icil_paper.paper import TABLES, claims_ledger, table_spec
from icil_paper.planning.design import claim_rows, stage_plan, with_row_seeds
from icil_paper.results import ResultsStore
from icil_paper.tables.execute import plan, plan_done


@dataclass(frozen=True)
class Look:
    """One look of a staged run: the seeds a row had, and what the stage rule made of it."""

    seeds: int
    """The stage's seeds a row (`tables.seed_stages[k]`)."""
    going_on: tuple[str, ...]
    """The rows ("TABLE:row") that go on to the next stage."""
    over_budget: tuple[str, ...] = ()
    """The claims the stage rule would have sent on that the budget stopped
    (`tables.stage_budget_hours`)."""

    def to_dict(self) -> dict[str, Any]:
        return {"seeds": self.seeds, "going_on": list(self.going_on),
                "over_budget": list(self.over_budget)}


def at_stage(preset: Preset, k: int) -> Preset:
    """`preset` with every row a claim reads at its `k`-th stage's seeds (0: the first,
    -1: the last; the first is where a run starts, the last the most it can ask)."""
    seeds = preset.tables.seed_stages[k]
    return with_row_seeds(preset, {row: seeds for rows in claim_rows(preset).values()
                                   for row in rows})


def stage_done(preset: Preset, store: ResultsStore) -> bool:
    """True when every planned cell of `preset` has all its records in `store`."""
    return all(plan_done(store, p) for p in plan([table_spec(preset, t) for t in TABLES]))


def staged_preset(preset: Preset, store: ResultsStore | None = None
                  ) -> tuple[Preset, list[Look]]:
    """The preset at the stage its records have reached, and the looks taken so far.

    Without `seed_stages`, `preset` itself and no look. Otherwise every row a claim reads
    gets the first stage's seeds; while every cell of the current stage is stored, the
    ledger looks and the rows that the stage rule sends on get the next stage's seeds (the
    module docstring). The returned preset is the one whose missing cells the run computes
    now; when its cells are all stored and no row goes on, the run is finished."""
    stages = preset.tables.seed_stages
    if not stages:
        return preset, []
    store = store or ResultsStore(preset.name)
    seeds = {row: stages[0] for rows in claim_rows(preset).values() for row in rows}
    stops: tuple[str, ...] = ()
    current = _at(preset, seeds, stops)
    looks: list[Look] = []
    for stage in stages:
        if not stage_done(current, store):
            break
        ledger = [e.to_dict() for e in claims_ledger(current, store)]
        rule = stage_plan(current, ledger, preset.tables.stage_budget_hours)
        going = {row: nxt for row, (nxt, _) in rule["continue"].items()
                 if nxt > seeds.get(row, 0)}
        stops += tuple(rule["over_budget"])
        looks.append(Look(stage, tuple(f"{t}:{r}" for t, r in sorted(going)),
                          tuple(rule["over_budget"])))
        seeds.update(going)
        current = _at(preset, seeds, stops)
        if not going:
            break
    return current, looks


def _at(preset: Preset, seeds: dict[tuple[str, str], int], stops: tuple[str, ...]) -> Preset:
    """`preset` with the rows of `seeds` at those seeds and `stops` as its `stage_stops`."""
    grown = with_row_seeds(preset, seeds)
    return replace(grown, tables=replace(grown.tables, stage_stops=stops))


def as_run(preset: Preset, store: ResultsStore | None = None) -> Preset:
    """The preset at the seeds its run has reached (`staged_preset`; a preset without seed
    stages is itself): what the book, the ledger and the cost read. Remembered per preset
    and results folder for the life of the process (a chapter asks several times; the
    records it reads do not change while it runs); `reproduce`, whose records do change,
    asks `staged_preset`."""
    if not preset.tables.seed_stages:
        return preset
    store = store or ResultsStore(preset.name)
    return _as_run(preset, str(store.root))


@functools.lru_cache(maxsize=8)
def _as_run(preset: Preset, root: str) -> Preset:
    return staged_preset(preset, ResultsStore(preset.name, root=Path(root)))[0]
