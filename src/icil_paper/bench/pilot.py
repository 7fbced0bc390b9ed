"""The pilot that sets the reference preset's task scale: is each family and task informative?

    python -m icil_paper.bench.pilot                      # every setting, 2 cells at a time
    python -m icil_paper.bench.pilot --settings kitchen_30

A row whose success is 0 or 1 on a family for every row of a table cannot tell the rows
apart there: averaging it in only dilutes the differences. The reference preset's task
settings (demonstrations per task, training steps; the experts are scripted, so more
demonstrations cost only their generation) were chosen from this pilot: one training seed
of the rows that bound each table's range (Table I's ICRT + LipVQ-VAE and BC-Transformer on
the kitchen suite; Table II's ACT on each ManiSkill task) at each setting of `SETTINGS`,
on the reference preset otherwise, evaluated as the tables evaluate them.

Each setting's cells run through the tables' own `run_cell` on a results folder of their
own (`results/pilot/`, not committed; a rerun skips what is stored), and the summary, each
row's success per task and per family, goes to `results/bench/pilot.json`, which the
chapters quote. One seed: these numbers place a family between 0 and 1, they do not rank
the rows.
"""

from __future__ import annotations

import argparse
import json
import os
from typing import Any

SETTINGS: dict[str, tuple[str, tuple[str, ...]]] = {
    "kitchen_10": ("I", ("data.demos_per_task=10",)),
    "kitchen_30": ("I", ("data.demos_per_task=30",)),
    "kitchen_10_1500": ("I", ("data.demos_per_task=10", "train.steps=1500")),
    "kitchen_10_2000": ("I", ("data.demos_per_task=10", "train.steps=2000")),
    "maniskill_40": ("II", ("tables.maniskill_demos_per_task=40",)),
    "maniskill_100": ("II", ("tables.maniskill_demos_per_task=100",)),
    "maniskill_40_5000": ("II", ("tables.maniskill_demos_per_task=40",
                                 "tables.maniskill_steps=5000")),
}
"""Setting -> (the table whose cells it runs, preset overrides on the reference preset)."""

ROWS = {"I": (("icrt", "lipvq"), ("bc_transformer", None)), "II": (("act", None),)}
"""The rows the pilot trains, per table: (policy, tokenizer)."""

PILOT_FOLDER = "pilot"
"""Under the results and runs roots: the pilot's own records and checkpoints."""


def setting_preset(name: str) -> Any:
    """The reference preset with the setting's overrides."""
    from icil_paper.config import get_preset
    from icil_paper.registry import check_name

    _, overrides = SETTINGS[check_name("pilot setting", name, SETTINGS)]
    return get_preset("reference").with_overrides(list(overrides))


def setting_plans(name: str) -> list[Any]:
    """The tables' RunPlans of the setting's rows (the first training seed only), their
    evaluations without the features."""
    from icil_paper.tables.definitions import table_spec
    from icil_paper.tables.execute import RunPlan, plan

    preset = setting_preset(name)
    table, _ = SETTINGS[name]
    wanted = set(ROWS[table])
    out = []
    for p in plan([table_spec(preset, table)]):
        tok = p.run.tokenizer.type if p.run.tokenizer is not None else None
        if (p.run.policy.type, tok) in wanted and p.run.seed == preset.seed:
            out.append(RunPlan(p.run, p.evals))  # success only: no features
    return out


def _summary(name: str, store: Any) -> list[dict[str, Any]]:
    """Each row's success per task and per family from the stored records (None: not run)."""
    from icil_paper.records import eval_record
    from icil_paper.tables.definitions import families

    rows = []
    for p in setting_plans(name):
        per_task = {}
        for ev in p.evals.values():
            record = store.get(*eval_record(p.run, ev))
            per_task[ev.task] = None if record is None else record["metrics"]["success_rate"]
        fam = {}
        if p.run.data.tasks[0].startswith("kitchen/"):
            for column, tasks in families(list(per_task)).items():
                values = [per_task[t] for t in tasks]
                fam[column] = (None if not values or None in values
                               else round(sum(values) / len(values), 4))
        rows.append({"row": p.run.label, "tasks": per_task, "families": fam,
                     "demos_per_task": p.run.data.demos_per_task,
                     "train_steps": p.run.train.steps,
                     "episodes_per_task": next(iter(p.evals.values())).episodes})
    return rows


def informative(summary: list[dict[str, Any]]) -> dict[str, bool]:
    """Column (family, or task where rows have no families) -> whether the setting's rows
    can be told apart there: False where every row is at 0, or every row at 1 (the rule of
    `icil_paper.tables.book.uninformative_columns`)."""
    values: dict[str, list[float | None]] = {}
    for row in summary:
        for column, value in (row["families"] or row["tasks"]).items():
            values.setdefault(column, []).append(value)
    return {column: not (None not in v and (all(x == 0.0 for x in v) or all(x == 1.0 for x in v)))
            for column, v in values.items()}


def setting_cells(name: str, progress: bool = True) -> list[Any]:
    """The grid cells of the setting's plans not yet stored (their data generated first)."""
    from icil_paper.config_data import to_dict
    from icil_paper.results import ResultsStore
    from icil_paper.tables.execute import cell_label, ensure_data, plan_done
    from icil_paper.tables.grid import Cell

    preset = setting_preset(name)
    store = ResultsStore(preset.name)
    todo = [p for p in setting_plans(name) if not plan_done(store, p)]
    if todo:
        ensure_data(preset, todo, progress=progress)
    return [Cell(key=p.run.key(), target="icil_paper.tables.execute:run_cell",
                 kwargs={"preset": preset.name, "run": p.run.to_dict(),
                         "evals": [to_dict(e) for e in p.evals.values()], "features": []},
                 label=f"{name}: {cell_label(p.run)}")
            for p in todo]


def main(argv: list[str] | None = None) -> None:
    from pathlib import Path

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    from icil_paper.bench import save_benchmark
    from icil_paper.results import results_root

    root = results_root()
    os.environ["ICIL_RESULTS"] = str(root / PILOT_FOLDER)
    os.environ.setdefault("ICIL_RUNS", str(Path("runs") / PILOT_FOLDER))
    from icil_paper.results import ResultsStore
    from icil_paper.tables.grid import run_grid

    cells = {c.key: c for name in args.settings for c in setting_cells(name)}
    cells = sorted(cells.values(), key=lambda c: "icrt" not in c.label)  # longest first
    run_grid(cells, workers=args.workers)
    store = ResultsStore("reference")
    out = Path(args.out or root / "bench" / "pilot.json")
    # settings not rerun keep their stored summary (a pilot is run a setting at a time)
    record = {"settings": json.loads(out.read_text())["settings"] if out.exists() else {}}
    for name in args.settings:
        summary = _summary(name, store)
        record["settings"][name] = {"table": SETTINGS[name][0],
                                    "overrides": list(SETTINGS[name][1]),
                                    "rows": summary, "informative": informative(summary)}
        print(f"== {name}: {record['settings'][name]}", flush=True)
    save_benchmark("pilot", record, out)


if __name__ == "__main__":
    main()


def pilot_frame(path: str | None = None, table: str = "I"):
    """The stored pilot (`results/bench/pilot.json`) as a table: one line per setting and
    row (its demonstrations per task and training steps), its success per family (Table
    II: per task) and on average; and, per setting, the columns that its rows cannot
    separate (every row at 0, or every one at 1; `informative`).
    Returns (frame, {setting: [uninformative columns]})."""
    import pandas as pd

    from icil_paper.bench import bench_path
    from icil_paper.tables.definitions import FAMILY_COLUMNS

    record = json.loads(open(path or bench_path("pilot")).read())
    lines, flat = [], {}
    for name, setting in record["settings"].items():
        if setting["table"] != table:
            continue
        merged: dict[tuple[str, str], dict] = {}  # Table II stores one row per task
        for row in setting["rows"]:
            where = (f"{row['demos_per_task']} demos, {row['train_steps']} steps, "
                     f"{row['episodes_per_task']} episodes")
            line = merged.setdefault((where, row["row"]), {"columns": {}, "tasks": {}})
            line["tasks"].update(row["tasks"])
            if table == "I":
                line["columns"].update({c: row["families"].get(c) for c in FAMILY_COLUMNS})
            else:
                line["columns"].update({t.split("/", 1)[1]: v for t, v in row["tasks"].items()})
        for (where, label), line in merged.items():
            tasks = [v for v in line["tasks"].values() if v is not None]
            lines.append({"setting": where, "row": label, **line["columns"],
                          "avg": round(sum(tasks) / len(tasks), 3) if tasks else None})
        label = lines[-1]["setting"] if lines else name
        flat[label] = sorted(c.split("/")[-1] for c, ok in informative(setting["rows"]).items()
                             if not ok)
    frame = pd.DataFrame(lines).set_index(["setting", "row"])
    return frame.sort_index(), flat


def uninformative_markdown(flat: dict[str, list[str]]) -> str:
    """`pilot_frame`'s uninformative columns per setting as a Markdown list."""
    return ("Columns that no row of a setting separates (every row at 0, or every one at 1):"
            "\n\n" + "\n".join(f"- {setting}: {', '.join(cols) or 'none'}"
                                for setting, cols in flat.items()))


def show_pilot(table: str = "I", path: str | None = None) -> None:
    """Chapters 06 and 07's view of the pilot: `pilot_frame` for `table`, then the columns
    each setting cannot separate."""
    from IPython.display import Markdown, display

    frame, flat = pilot_frame(path, table=table)
    display(frame)
    display(Markdown(uninformative_markdown(flat)))
