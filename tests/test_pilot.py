"""The pilot behind the reference preset's task scale, as chapters 06 and 07 show it."""

import json

from icil_paper.planning.pilot import pilot_frame


def _row(row, tasks, families=None, steps=2000):
    return {"row": row, "demos_per_task": 40, "train_steps": steps, "episodes_per_task": 10,
            "tasks": tasks, "families": families or {}}


def test_table_two_shows_one_line_per_setting_and_row_with_a_column_per_task(tmp_path):
    rows = [_row("act", {"maniskill/pick_cube": 0.2}), _row("act", {"maniskill/push_cube": 0.8}),
            _row("act", {"maniskill/stack_cube": 0.0})]
    path = tmp_path / "pilot.json"
    path.write_text(json.dumps({"settings": {"m": {"table": "II", "rows": rows}}}))
    frame, flat = pilot_frame(str(path), table="II")
    assert len(frame) == 1 and frame.index[0][1] == "act"
    line = frame.iloc[0]
    assert (line["pick_cube"], line["push_cube"], line["stack_cube"]) == (0.2, 0.8, 0.0)
    assert abs(line["avg"] - 1 / 3) < 1e-3
    assert flat == {"40 demos, 2000 steps, 10 episodes": ["stack_cube"]}


def test_table_one_averages_over_tasks_and_flags_columns_no_row_separates(tmp_path):
    tasks = {"kitchen/open_door": 1.0, "kitchen/open_drawer": 0.0}
    rows = [_row("icrt+lipvq", tasks, {"doors": 1.0, "drawers": 0.0}),
            _row("bc_transformer", {"kitchen/open_door": 0.5, "kitchen/open_drawer": 0.0},
                 {"doors": 0.5, "drawers": 0.0})]
    path = tmp_path / "pilot.json"
    path.write_text(json.dumps({"settings": {"k": {"table": "I", "rows": rows}}}))
    frame, flat = pilot_frame(str(path), table="I")
    assert frame.loc[("40 demos, 2000 steps, 10 episodes", "icrt+lipvq"), "avg"] == 0.5
    assert flat["40 demos, 2000 steps, 10 episodes"] == ["drawers"]
