"""Per-task demonstration counts (`data.task_demos`): what a run trains on, the data the plan
generates, the held-out start, and the keys of runs that do not use them."""

from collections import Counter

import pytest

from icil_paper.config import get_preset, task_demo_counts
from icil_paper.config_data import ConfigError, OverrideError
from icil_paper.runspec import DataSpec, run_spec

TASKS = ("synthetic/task0", "synthetic/task1")  # the simulator-free suite
KITCHEN = ("kitchen/open_drawer", "kitchen/close_drawer", "kitchen/open_door")


def test_entries_parse_and_bad_ones_name_the_form():
    assert task_demo_counts(["kitchen/open_drawer:10", "kitchen/close_drawer:4"]) == {
        "kitchen/open_drawer": 10, "kitchen/close_drawer": 4}
    for bad in (["kitchen/open_drawer"], ["kitchen/open_drawer:0"], ["kitchen/open_drawer:x"],
                ["a:2", "a:3"]):
        with pytest.raises(ConfigError, match="task_demos"):
            task_demo_counts(bad)
    with pytest.raises(OverrideError, match="TASK:N"):
        get_preset("smoke").with_overrides(["data.task_demos=kitchen/open_drawer"])


def test_a_run_carries_the_exceptions_of_its_own_tasks_only():
    preset = get_preset("small").with_overrides(
        ["data.task_demos=kitchen/open_drawer:10,maniskill/stack_cube:7"])
    run = run_spec(preset, "icrt", "lipvq", tasks=KITCHEN)
    assert run.data.task_demos == ("kitchen/open_drawer:10",)
    assert run.data.demos_for("kitchen/open_drawer") == 10
    assert run.data.demos_for("kitchen/open_door") == preset.data.demos_per_task
    assert run.data.most_demos == 10
    one = run_spec(preset, "act", "lipvq", tasks=["maniskill/pick_cube"])
    assert one.data.task_demos == ()


def test_without_exceptions_a_run_keeps_the_key_it_had_before_the_option():
    preset = get_preset("small")
    run = run_spec(preset, "icrt", "lipvq", tasks=KITCHEN)
    from icil_paper.config_data import content_hash, to_dict

    keyed = to_dict(run, keyed_only=True)
    assert "task_demos" not in keyed["data"]
    assert run.key() == content_hash(keyed)
    more = run_spec(preset.with_overrides(["data.task_demos=kitchen/close_drawer:9"]), "icrt",
                    "lipvq", tasks=KITCHEN)
    assert more.key() != run.key()


def test_training_reads_and_the_plan_generates_each_tasks_own_count(monkeypatch, tmp_path):
    from icil_paper.tables.cells import RunPlan, data_needs
    from icil_paper.train.loop import training_demos

    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    data = DataSpec(tasks=TASKS, demos_per_task=2, task_demos=("synthetic/task1:4",))
    demos = training_demos(data, preset="smoke", progress=False)
    assert Counter(d.task for d in demos) == {"synthetic/task0": 2, "synthetic/task1": 4}
    run = run_spec(get_preset("smoke"), "icrt", "lipvq", tasks=TASKS).replace(data=data)
    needs = data_needs([RunPlan(run)])
    assert {key[0]: n for key, n in needs.items()} == {"synthetic/task0": 2,
                                                        "synthetic/task1": 4}


def test_held_out_trajectories_start_after_every_tasks_training_demonstrations():
    from icil_paper.tables.definitions import feature_spec

    more = get_preset("small").data.demos_per_task + 3
    preset = get_preset("small").with_overrides([f"data.task_demos=kitchen/close_drawer:{more}"])
    run = run_spec(preset, "icrt", "lipvq", tasks=KITCHEN)
    assert feature_spec(preset, run).start == more
    plain = run_spec(get_preset("small"), "icrt", "lipvq")
    assert feature_spec(get_preset("small"), plain).start == plain.data.demos_per_task
