"""Seeds in stages, run: the seeds of every row at the stage a preset's run has reached.

A preset with `tables.seed_stages` (the reference preset: 5, 10, 15) registers its design in
`results/<preset>/design.json` before its first cell. Every row a claim reads starts at the
first stage's seeds; once every cell of a stage is stored, the ledger looks and the stage
rule (`design.stage_plan`) sends rows on. Each look is written to the record as it is
taken, so the seeds a row has are read from the record, not recomputed. Rows no claim reads
keep the seeds the preset lists.

    preset, looks = staged_preset(get_preset("reference"))   # this sitting's seeds per row
    icil-paper reproduce --preset reference                   # runs the stages in turn

A record labelled "older" holds an earlier design's looks: the preset is read at its
fields and the run is over. A record whose design differs from the preset's is refused.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from icil_paper.config import Preset
from icil_paper.config_data import ConfigError
from icil_paper.paper import TABLES, claims_ledger, table_spec
from icil_paper.planning.design import claim_rows, stage_plan, with_row_seeds
from icil_paper.results import ResultsStore
from icil_paper.tables.cells import plan, plan_done
from icil_paper.tables.design import new_record, read_record, record_path, write_record


@dataclass(frozen=True)
class Look:
    """One look of a staged run: the seeds a row had, and what the stage rule made of it."""

    seeds: int
    """The stage's seeds a row (`tables.seed_stages[k]`)."""
    going_on: tuple[str, ...]
    """The rows ("TABLE:row") that go on to the next stage."""
    over_budget: tuple[str, ...] = ()
    """The claims the stage rule would have sent on that the budget stopped."""
    rows: dict[str, int] = field(default_factory=dict, compare=False)
    """Every claimed row's seeds at the look ("TABLE:row" -> seeds)."""
    next_seeds: int | None = None
    """The seeds a row that goes on gets (the next stage)."""

    def to_dict(self) -> dict[str, Any]:
        return {"seeds": self.seeds, "rows": dict(sorted(self.rows.items())),
                "going_on": dict.fromkeys(self.going_on, self.next_seeds),
                "over_budget": list(self.over_budget)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Look:
        going = d.get("going_on") or {}
        return cls(int(d["seeds"]), tuple(going), tuple(d.get("over_budget", ())),
                   dict(d.get("rows", {})), next(iter(going.values()), None))


def at_stage(preset: Preset, k: int) -> Preset:
    """`preset` with every row a claim reads at its `k`-th stage's seeds (-1: the last)."""
    seeds = preset.tables.seed_stages[k]
    return with_row_seeds(preset, {row: seeds for rows in claim_rows(preset).values()
                                   for row in rows})


def stage_done(preset: Preset, store: ResultsStore) -> bool:
    """True when every planned cell of `preset` has all its records in `store`."""
    return all(plan_done(store, p) for p in plan([table_spec(preset, t) for t in TABLES]))


def _recorded(preset: Preset, store) -> tuple[dict[str, Any], Preset]:
    """The store's design record (a new one where it has none) and the preset at its fields."""
    record = read_record(store) if hasattr(store, "dir") else None
    fresh = new_record(preset)
    if record is None:
        return fresh, preset
    if record["design"] != "older" and record["tables"] != fresh["tables"]:
        raise ConfigError(f"{record_path(store)} registers another design ({record['tables']}) "
                          f"than the preset's ({fresh['tables']}): a design does not change "
                          "during a run; restore the preset's fields or start a new store")
    fields = {k: tuple(v) if isinstance(v, list) else v for k, v in record["tables"].items()}
    return record, replace(preset, tables=replace(preset.tables, **fields))


def staged_preset(preset: Preset, store: ResultsStore | None = None, write: bool = False
                  ) -> tuple[Preset, list[Look]]:
    """(the preset at the stage its run has reached, the looks so far): the recorded looks,
    then a new look for each stage whose cells are all stored. With `write` (`reproduce`),
    the record and each new look are written; the book reads without writing."""
    stages = preset.tables.seed_stages
    if not stages:
        return preset, []
    store = store or ResultsStore(preset.name)
    record, base = _recorded(preset, store)
    if write and not record_path(store).exists():
        write_record(store, record)  # the design, registered before any new data
    seeds = {f"{t}:{r}": stages[0] for rows in claim_rows(base).values() for t, r in rows}
    looks = [Look.from_dict(d) for d in record["looks"]]
    stops: tuple[str, ...] = ()
    for look in looks:
        seeds.update(dict.fromkeys(look.going_on, look.next_seeds))
        stops += look.over_budget
    current = _at(base, seeds, stops)
    if record["design"] == "older" or (looks and not looks[-1].going_on):
        return current, looks  # the run is over
    for k in range(len(looks), len(stages)):
        if not stage_done(current, store):
            break
        ledger = [e.to_dict() for e in claims_ledger(current, store)]
        rule = stage_plan(current, ledger, base.tables.stage_budget_hours)
        going = {f"{t}:{r}": n for (t, r), (n, _) in rule["continue"].items()
                 if n > seeds.get(f"{t}:{r}", 0)}
        looks.append(Look(stages[k], tuple(sorted(going)), tuple(rule["over_budget"]),
                          {r: n for r, n in seeds.items() if n >= stages[k]},
                          stages[k + 1] if going else None))
        record["looks"].append(looks[-1].to_dict())
        if write:
            write_record(store, record)
        seeds.update(going)
        stops += tuple(rule["over_budget"])
        current = _at(base, seeds, stops)
        if not going:
            break
    return current, looks


def _at(preset: Preset, seeds: dict[str, int], stops: tuple[str, ...]) -> Preset:
    """`preset` with the rows of `seeds` ("TABLE:row" -> seeds) and `stops` as `stage_stops`."""
    grown = with_row_seeds(preset, {tuple(row.split(":", 1)): n for row, n in seeds.items()})
    return replace(grown, tables=replace(grown.tables, stage_stops=stops))


def as_run(preset: Preset, store: ResultsStore | None = None) -> Preset:
    """The preset at the seeds its run has reached (`staged_preset`), cached per results folder."""
    if not preset.tables.seed_stages:
        return preset
    store = store or ResultsStore(preset.name)
    return _as_run(preset, str(store.root))


@functools.lru_cache(maxsize=8)
def _as_run(preset: Preset, root: str) -> Preset:
    return staged_preset(preset, ResultsStore(preset.name, root=Path(root)))[0]
