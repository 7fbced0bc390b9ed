"""Chapter 02's run: a small ICRT + LipVQ-VAE trained on one Meta-World task and rolled out
from prompts, as a table of one entry.

    spec(preset)                          # one row (icrt+lipvq), one column (the task)
    run, evaluation = icrt_specs(preset)  # the entry's training run and its evaluation
    records = icrt_records(preset, store) # {"train": ..., "eval": ...} metrics, or None

One training seed (more through `tables.row_seeds`), trained on `ICRT_DEMO_TASK` alone and
evaluated there as every table evaluates; no paper's numbers and no claims.
"""

from __future__ import annotations

from typing import Any

from icil_paper.config import Preset
from icil_paper.records import eval_record, train_record
from icil_paper.results import ResultsStore
from icil_paper.runspec import EvalSpec, RunSpec
from icil_paper.tables.definitions import label, row_seeds, seed_runs, tasks_entry
from icil_paper.tables.spec import Row, TableSpec

ICRT_DEMO_TASK = "metaworld/drawer-open"
"""Chapter 02's task: one small ICRT trained and rolled out on it."""
ICRT_DEMO_TOKENIZER = "lipvq"
"""Chapter 02's action tokenizer (the paper's LipVQ-VAE)."""
ICRT_DEMO_ROW = label("icrt", ICRT_DEMO_TOKENIZER)
"""The table's one row."""
ICRT_DEMO_COLUMN = ICRT_DEMO_TASK.split("/", 1)[1]
"""The table's one column: success on the task."""


def spec(preset: Preset) -> TableSpec:
    """Chapter 02's run as a table: ICRT + LipVQ-VAE trained on `ICRT_DEMO_TASK`, its
    success there from prompts, one entry."""
    seeds = row_seeds(preset, "icrt", ICRT_DEMO_ROW, 1)
    runs = seed_runs(preset, "icrt", ICRT_DEMO_TOKENIZER, [ICRT_DEMO_TASK], seeds)
    row = Row(ICRT_DEMO_ROW, {ICRT_DEMO_COLUMN: tasks_entry(preset, runs, [ICRT_DEMO_TASK])})
    return TableSpec("icrt", "A small ICRT + LipVQ-VAE, trained and rolled out on one task",
                     (ICRT_DEMO_COLUMN,), (row,), note=(
                         f"Trained on {ICRT_DEMO_TASK} alone and evaluated there from "
                         "prompts (chapter 02); not a table of the paper."))


def icrt_specs(preset: Preset) -> tuple[RunSpec, EvalSpec]:
    """The run and evaluation of the table's seed 0: what chapter 02 shows and replays."""
    unit = spec(preset).rows[0].entries[ICRT_DEMO_COLUMN].units[0]
    return unit.run, unit.eval


def icrt_records(preset: Preset, store: ResultsStore | None = None
                 ) -> dict[str, dict[str, Any]] | None:
    """{"train": ..., "eval": ...}: seed 0's train and eval records' metrics, or None while
    either is missing."""
    store = store or ResultsStore(preset.name)
    run, ev = icrt_specs(preset)
    trained, evaluated = store.get(*train_record(run)), store.get(*eval_record(run, ev))
    if trained is None or evaluated is None:
        return None
    return {"train": trained["metrics"], "eval": evaluated["metrics"]}
