"""The prompt ablation (our own): does the prompt carry the task? Chapters 06 and 10.

    spec(preset)                              # ICRT + LipVQ-VAE: right, another task's, cut prompt
    prompt_beside_baselines(table1, prompt)   # beside Table I's rows that read no prompt

Table I's ICRT + LipVQ-VAE runs evaluated with its task's prompt, another task's
(`other_task`) and the first `tables.prompt_steps` steps of its own. No claims.
"""

from __future__ import annotations

from collections.abc import Sequence

from icil_paper.config import Preset
from icil_paper.tables.assemble import TableResult, format_entry
from icil_paper.tables.definitions import evaluation, table_i_runs, tasks_entry
from icil_paper.tables.display import source_label
from icil_paper.tables.spec import Entry, Row, TableSpec, Unit


def other_task(task: str, tasks: Sequence[str]) -> str:
    """The task whose prompt stands in as the wrong one: the same fixture's opposite goal
    (`metaworld/drawer-open` -> `metaworld/drawer-close`) where there is one, else the next."""
    suite, name = task.split("/", 1)
    swaps = [f"{suite}/{b}{name[len(a):]}" for a, b in (("open_", "close_"), ("close_", "open_"))
             if name.startswith(a)]
    swaps += [f"{suite}/{name[:-len(a)]}{b}" for a, b in (("_on", "_off"), ("_off", "_on"),
                                                          ("-open", "-close"), ("-close", "-open"))
              if name.endswith(a)]
    for candidate in swaps:
        if candidate in tasks:
            return candidate
    return tasks[(list(tasks).index(task) + 1) % len(tasks)]


def spec(preset: Preset) -> TableSpec:
    """The prompt ablation's three rows x avg."""
    tasks = list(preset.data.robocasa_tasks)
    runs = table_i_runs(preset, "icrt", "lipvq")
    right = tasks_entry(preset, runs, tasks)
    wrong = Entry(tuple(Unit(s, run, evaluation(preset, run, task, s,
                                               prompt_task=other_task(task, tasks)))
                       for s, run in enumerate(runs) for task in tasks))
    short = tasks_entry(preset, runs, tasks, prompt_steps=preset.tables.prompt_steps)
    rows = (Row("right prompt", {"avg": right}),
            Row("another task's prompt", {"avg": wrong}),
            Row(f"first {preset.tables.prompt_steps} prompt steps", {"avg": short}))
    return TableSpec("prompt", "Does the prompt carry the task? (ICRT + LipVQ-VAE)", ("avg",),
                     rows, note=(
                         "Table I's ICRT + LipVQ-VAE with its task's prompt, with the prompt of "
                         "another task (the same fixture's opposite goal where there is one), "
                         "and with only the first steps of its own prompt."))


PROMPT_BASELINES = ("bc_transformer", "act")
"""Table I's rows that read the instruction and no prompt, shown beside the prompt ablation."""


def prompt_beside_baselines(table1: dict[str, TableResult], prompt: dict[str, TableResult],
                            digits: int = 3):
    """The prompt ablation's rows beside Table I's baselines, which read the instruction and
    no prompt: average success with its 95% interval, one column per source."""
    import pandas as pd

    rows = [(f"ICRT + LipVQ-VAE, {row.label}", "instruction and prompt", prompt, row.label)
            for row in next(iter(prompt.values())).spec.rows]
    rows += [(label, "instruction only", table1, label) for label in PROMPT_BASELINES]
    out = [{"": name, "reads": reads, **{source_label(source, result.preset): format_entry(
                result.entry(row, "avg"), digits) for source, result in results.items()}}
           for name, reads, results, row in rows]
    return pd.DataFrame(out).set_index("")
