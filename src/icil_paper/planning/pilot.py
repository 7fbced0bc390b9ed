"""The pilots behind the reference preset, as the chapters read them: the task-scale pilot
(`results/bench/pilot.json`) and the regime pilot (`results/bench/regime.json`); they run
from `tools/pilot.py` (`make pilot`).

    show_pilot("I")                       # chapters 06 and 07: one line per setting and row
    frame, sentence = regime_summary()    # chapter 06: the regime the pilot chose, and why
    regime_episodes()["episodes"]         # Meta-World's cost-optimal episodes a task
"""

from __future__ import annotations

import json
import os
from typing import Any

import numpy as np

from icil_paper import stats
from icil_paper.results import bench_path
from icil_paper.tables.definitions import FAMILY_COLUMNS

REGIME_RANGE = (0.1, 0.9)
"""Every family of ICRT + LipVQ-VAE at the chosen budget should lie in this range."""
REGIME_MIN_FAMILIES = 5
"""The budget is the learning curve's plateau, unless fewer than this many families lie
within `REGIME_RANGE` there: then the largest budget below it where this many do."""


def informative(summary: list[dict[str, Any]]) -> dict[str, bool]:
    """Column (family, else task) -> False where every row is at 0, or every row at 1."""
    values: dict[str, list[float | None]] = {}
    for row in summary:
        for column, value in (row["families"] or row["tasks"]).items():
            values.setdefault(column, []).append(value)
    return {column: not (None not in v and (all(x == 0.0 for x in v) or all(x == 1.0 for x in v)))
            for column, v in values.items()}


def pilot_frame(path: str | None = None, table: str = "I"):
    """The stored pilot as (frame: success per family or task and on average, one line per
    setting and row; {setting: [uninformative columns]})."""
    import pandas as pd

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


def show_pilot(table: str = "I", path: str | None = None) -> None:
    """Display `pilot_frame` for `table`, then each setting's uninformative columns."""
    import pandas as pd
    from IPython.display import display

    frame, flat = pilot_frame(path, table=table)
    display(frame)
    display(pd.DataFrame({"uninformative columns": {k: ", ".join(v) or "none"
                                                    for k, v in flat.items()}}))


def regime_summary(path: str | None = None) -> tuple[Any, str]:
    """The stored regime pilot as (frame: success per family and learning curve by row,
    sentence: the budget chosen and why); (None, sentence) when there is no record."""
    import pandas as pd

    source = path or bench_path("regime")
    if not os.path.exists(source):
        return None, ("The regime pilot has not been run here (`make pilot "
                      "PILOT_ARGS=regime` writes `results/bench/regime.json`).")
    record = json.loads(open(source).read())
    lines = []
    for row, fam in record["families"].items():
        line = {"row": row, **{column: fam.get(column) for column in FAMILY_COLUMNS}}
        curve = record["learning_curve"].get(row, {})
        for steps in sorted(curve, key=int):
            line[f"avg at {steps} steps"] = curve[steps]
        lines.append(line)
    frame = pd.DataFrame(lines).set_index("row") if lines else None
    low, high = REGIME_RANGE
    outside = [f for f, ok in record.get("within_range", {}).items() if not ok]
    steps = record.get("train_steps")
    exceptions = record.get("task_demos") or {}
    own = (" (" + ", ".join(f"{t.split('/', 1)[-1]} {n}" for t, n in exceptions.items()) + ")"
           if exceptions else "")
    suite = record.get("suite", "kitchen")
    text = (f"On the {suite} tasks: {record['seeds']} pilot seed(s) (seed indices "
            f"{record['seed_indices']}, which the reference run does not use), "
            f"{record['demos_per_task']} demonstrations a task{own}; budgets "
            f"{record['budgets']}. ")
    data = record.get("data_curve")
    if data:
        curve = ", ".join(f"{n}: {v}" for n, v in data["curve"].items())
        text += (f"Data curve of {data['row']} at {data['train_steps']} steps "
                 f"({data['seeds']} seeds; demonstrations a task: success) {curve}; "
                 + ("the largest count gains nothing beyond noise over the one before it. "
                    if data["saturated"] else "it still rises at the largest count. "))
    done = record.get("budgets_done", record["budgets"])
    if steps is None:
        text += "No budget has all its records yet."
    elif not record["plateau_reached"] and len(done) < len(record["budgets"]):
        text += (f"The learning curve is incomplete: ICRT + LipVQ-VAE has every record at "
                 f"{done} steps only, so no plateau is chosen yet; the families below are "
                 f"at {steps} steps.")
    elif str(record.get("chosen_because")).startswith("in range below"):
        top = record["plateau_steps"] or max(record["budgets_done"])
        how = "levels off" if record["plateau_steps"] else "still rises"
        text += (f"ICRT + LipVQ-VAE's learning curve {how} at {top} steps, where only "
                 f"{record['families_in_range'].get(str(top))} of its families lie inside "
                 f"[{low}, {high}]; "
                 f"the regime trains {steps} steps, the most at which at least "
                 f"{REGIME_MIN_FAMILIES} do. There, its families outside the range: "
                 f"{', '.join(outside) or 'none'}.")
    else:
        text += (f"ICRT + LipVQ-VAE's learning curve {'levels off' if record['plateau_reached'] else 'still rises'} "
                 f"at {steps} steps; there, its families outside [{low}, {high}]: "
                 f"{', '.join(outside) or 'none'}.")
    shares = {row: [None if v is None else round(v, 3) for v in s]
              for row, s in record.get("capped_share", {}).items()}
    if shares:
        text += " Capped share of encoder rows per seed: " + "; ".join(
            f"{row} {s}" for row, s in shares.items()) + "."
    for row, tasks in record.get("maniskill", {}).items():
        text += (f" ManiSkill, {row} on each task: "
                 + ", ".join(f"{task} {value}" for task, value in tasks.items())
                 + f" (outside [{low}, {high}]: "
                 + (", ".join(t for t, v in tasks.items() if v is None or not low <= v <= high)
                    or "none") + ").")
    return frame, text


def recorded_episodes(path: str | None = None) -> dict[str, int]:
    """{suite: cost-optimal episodes per task} of `results/bench/episodes.json`."""
    rows = json.loads(open(path or bench_path("episodes")).read())["rows"]
    return {r["suite"]: round(r["optimal_episodes"]) for r in rows if r["pairs"] == "all pairs"}


def regime_episodes(path: str | None = None, cells: str | None = None) -> dict[str, Any]:
    """Meta-World's cost-optimal episodes per task from the regime pilot's paired outcomes
    (ICRT + LipVQ-VAE against each other row) and the cost of its cell (`cells.json`); where
    the seed-by-row part is 0, the count at which evaluation costs as much as training."""
    record = json.loads(open(path or bench_path("regime")).read())
    tasks = record["tasks"]

    def outcomes(row: str) -> np.ndarray:
        per_seed = record["outcomes"][row]
        return np.array([[per_seed[s][t] for t in tasks] for s in sorted(per_seed)], bool)

    lipvq = outcomes("icrt+lipvq")
    parts = [stats.paired_variance_parts(lipvq, outcomes(row))
             for row in record["outcomes"] if row != "icrt+lipvq"]
    episode, seed_by_row = (float(np.mean([p[i] for p in parts])) for i in (0, 1))
    cell = next(c for c in json.loads(open(cells or bench_path("cells")).read())["cells"]
                if c["kind"] == "icrt_lipvq")["steady"]
    train_s = cell["step_ms"] / 1000 * record["train_steps"]
    evaluation = sum(v for k, v in cell["phases_s"].items() if k.startswith("eval."))
    episode_s = evaluation / (cell["episodes"] / len(tasks))
    if seed_by_row > 0:
        best = stats.episodes_per_seed(seed_by_row, episode, train_s, episode_s)
    else:
        best = train_s / episode_s
    return {"episode_part": episode, "seed_by_row_part": seed_by_row, "pairs": len(parts),
            "train_s": round(train_s, 2), "episode_s": round(episode_s, 3),
            "episodes": max(1, round(best))}
