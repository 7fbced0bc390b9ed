"""Seeds in stages, run (`planning.staged`): every row a claim reads starts at the first
stage's seeds, and after each look only the rows the stage rule sends on grow."""

from types import SimpleNamespace

from icil_paper.config import get_preset
from icil_paper.paper import table_spec
from icil_paper.planning import staged
from icil_paper.planning.design import (
    claim_rows,
    plan_cost,
    stage_plan,
    with_row_seeds,
    within_budget,
)

STAGES = (2, 3, 4)


def _preset():
    """Smoke, staged, on two of its 13 tasks: the claims and their rows are the same (a row
    averages its tasks), and every plan priced here is a sixth of the size."""
    return get_preset("smoke").with_overrides(
        ["tables.icrt_seeds=2", "tables.baseline_seeds=2", "tables.seed_stages=2,3,4",
         "data.robocasa_tasks=metaworld/drawer-open,metaworld/button-press"])


def _seeds(preset, table, row):
    spec = table_spec(preset, table).row(row)
    return len({u.seed_index for entry in spec.entries.values() for u in entry.units})


def _records_through(monkeypatch, stage):
    """Every cell of stages 1..`stage` stored; the ledger's first look sends on the rows of
    I-tokenizer-gap only, its second look none."""
    def stage_done(preset, store):
        claimed = {f"{t}:{r}" for rows in claim_rows(preset).values() for t, r in rows}
        seeds = preset.tables.seeds_by_row()
        return stage and max(seeds[row] for row in claimed) <= STAGES[stage - 1]

    def ledger(preset, store):
        first = max(preset.tables.seeds_by_row().values()) == STAGES[0]
        return [SimpleNamespace(to_dict=lambda c=c: {
            "id": c, "sequential": {"next": 3 if first and c == "I-tokenizer-gap" else None}})
            for c in claim_rows(preset)]

    monkeypatch.setattr(staged, "stage_done", stage_done)
    monkeypatch.setattr(staged, "claims_ledger", ledger)


def test_a_preset_without_stages_is_run_as_it_is():
    preset = get_preset("smoke")
    assert staged.staged_preset(preset) == (preset, [])


def test_every_claimed_row_starts_at_the_first_stage(monkeypatch):
    _records_through(monkeypatch, 0)
    preset = _preset().with_overrides(["tables.icrt_seeds=5"])
    current, looks = staged.staged_preset(preset, store=object())
    assert looks == []
    assert _seeds(current, "I", "icrt+lipvq") == 2 == _seeds(current, "I", "bc_transformer")
    assert _seeds(current, "I", "mcr") == _seeds(preset, "I", "mcr")  # no claim reads it


def test_after_a_look_only_the_rows_sent_on_grow_and_the_last_look_stops(monkeypatch):
    _records_through(monkeypatch, 1)
    current, looks = staged.staged_preset(_preset(), store=object())
    assert [look.seeds for look in looks] == [2]
    assert set(looks[0].going_on) >= {"I:icrt+mlp", "I:icrt+lipvq", "IV:icrt+mlp"}
    assert _seeds(current, "I", "icrt+lipvq") == 3 == _seeds(current, "IV", "icrt+mlp")
    assert _seeds(current, "I", "bc_transformer") == 2
    _records_through(monkeypatch, 2)
    again, looks = staged.staged_preset(_preset(), store=object())
    assert [look.seeds for look in looks] == [2, 3] and looks[-1].going_on == ()
    assert again == current  # nothing goes on: the run is finished


def _hours(preset):
    return plan_cost(preset)["core_s"] / 2 / 3600


def test_the_budget_takes_the_cheapest_claims_that_fit_and_stops_the_others():
    """`design.within_budget` against whole plans priced by `plan_cost`: what it takes fits
    the budget, each claim it stops would not have fitted, and no budget takes them all."""
    preset = staged.at_stage(_preset(), 0)
    wanted = {c: 3 for c in claim_rows(preset)}
    base = _hours(preset)
    everything = stage_plan(preset, [{"id": c, "sequential": {"next": 3}} for c in wanted])
    top = _hours(with_row_seeds(preset, {r: n for r, (n, _) in everything["continue"].items()}))
    assert within_budget(preset, wanted, top + 1) == (wanted, {})
    assert within_budget(preset, wanted, base) == ({}, wanted)  # every next stage costs

    def grown(claims):
        rows = stage_plan(preset, [{"id": c, "sequential": {"next": 3}} for c in claims])
        return _hours(with_row_seeds(preset, {r: n for r, (n, _) in rows["continue"].items()}))

    budget = (base + top) / 2
    taken, over = within_budget(preset, wanted, budget)
    assert taken and over and set(taken) | set(over) == set(wanted)
    assert grown(taken) <= budget + 1e-9
    for claim_id in over:
        assert grown({**taken, claim_id: 3}) > budget, claim_id


def test_the_budget_stops_a_claim_and_the_preset_carries_it(monkeypatch):
    _records_through(monkeypatch, 1)
    tight = _hours(staged.at_stage(_preset(), 0)) + 1e-6
    preset = _preset().with_overrides([f"tables.stage_budget_hours={tight}"])
    current, looks = staged.staged_preset(preset, store=object())
    assert looks[0].going_on == () and looks[0].over_budget == ("I-tokenizer-gap",)
    assert current.tables.stage_stops == ("I-tokenizer-gap",)
    assert _seeds(current, "I", "icrt+lipvq") == 2  # nothing grew
    assert staged.staged_preset(preset, store=object())[0] == current  # the same next time


def test_the_reference_first_stage_fits_its_budget_and_the_last_does_not():
    preset = get_preset("reference")
    budget = preset.tables.stage_budget_hours
    assert _hours(staged.at_stage(preset, 0)) <= budget < _hours(staged.at_stage(preset, -1))
