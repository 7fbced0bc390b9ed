"""The paper's RoboCasa tables on Meta-World: the tasks each table trains and evaluates on,
and the one-line errors a user gets before any work."""

from __future__ import annotations

import pytest

from cli_helpers import run_cli
from icil_paper.config import get_preset
from icil_paper.paper import table_spec
from icil_paper.paper.table_v import sim_to_real_runs
from icil_paper.tables.definitions import FAMILY_COLUMNS, families


def test_every_family_of_table_i_has_meta_world_tasks():
    tasks = get_preset("small").data.robocasa_tasks
    assert all(t.startswith("metaworld/") for t in tasks) and len(tasks) == 13
    by_family = families(tasks)
    assert list(by_family) == list(FAMILY_COLUMNS)
    assert all(by_family.values())  # no family without a task
    assert by_family["levers"] == ["metaworld/faucet-open", "metaworld/faucet-close"]
    assert sorted(sum(by_family.values(), [])) == sorted(tasks)  # each task in one family


def test_table_i_trains_every_row_on_the_meta_world_tasks_only():
    preset = get_preset("small")
    for unit in table_spec(preset, "I").units():
        assert set(unit.run.data.tasks) == set(preset.data.robocasa_tasks)
        assert unit.eval is None or unit.eval.task in preset.data.robocasa_tasks


def test_the_sim_to_real_table_trains_on_the_panda_twins_of_the_kinova_tasks():
    preset = get_preset("small")
    runs = sim_to_real_runs(preset, "icrt", "lipvq")
    assert set(runs[0].data.tasks) == {"kitchen/open_door", "kitchen/close_door",
                                       "kitchen/open_drawer", "kitchen/close_drawer"}
    for unit in table_spec(preset, "V").units():
        assert unit.eval is not None and unit.eval.task.startswith("kinova/")
        assert not any(t.startswith("metaworld/") for t in unit.run.data.tasks)


def test_the_cross_dataset_table_plays_the_human_scenes_with_human_prompts():
    preset = get_preset("small")
    for unit in table_spec(preset, "VI").units():
        assert unit.eval is not None and unit.eval.scenes == "human"
        assert unit.eval.task.startswith("metaworld/")
        if unit.run.policy.type == "icrt":
            assert unit.eval.prompt_source == "human"


@pytest.mark.parametrize("argv,phrase", [
    (["train", "--tasks", "metaworld/drawer-opn"], "Did you mean 'metaworld/drawer-open'"),
    (["reproduce", "--set", "data.zero_shot_tasks=metaworld/reach,metaworld/bin-picking"],
     "metaworld/bin-picking, held out for the zero-shot table"),
    (["reproduce", "--set", "data.zero_shot_held_out=kitchen/open_drawer"],
     "unknown data.zero_shot_held_out task"),
])
def test_bad_meta_world_input_is_one_line_and_exit_2(argv, phrase, tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "results"))
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "runs"))
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    code, err = run_cli(*argv, "--preset", "smoke")
    assert code == 2, err
    assert phrase in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "results").exists() and not (tmp_path / "data").exists()


def test_a_missing_meta_world_install_stops_before_any_work(tmp_path, monkeypatch):
    import icil_paper.data.generate as generate

    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "results"))
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    monkeypatch.setattr(generate, "suite_unavailable", lambda suite: (
        "metaworld is not installed: run `make setup`" if suite == "metaworld" else None))
    code, err = run_cli("reproduce", "--preset", "smoke")
    assert code == 2
    assert "cannot run here: metaworld is not installed: run `make setup`" in err
    assert not (tmp_path / "data").exists()


def test_the_task_names_the_presets_read_are_the_suites_own():
    from icil_paper import benchmark_tasks as names
    from icil_paper.sim.metaworld import tasks

    assert tasks.TASK_FAMILIES == names.ROBOCASA_FAMILIES
    assert tasks.ROBOCASA_TASKS == names.ROBOCASA_TASKS
    assert set(names.ML45_TRAIN) | set(names.ML45_HELD_OUT) == set(tasks.TASKS)


@pytest.mark.parametrize("name", ["small", "reference"])
def test_icrt_sequences_fit_every_meta_world_horizon(name):
    """One prompt episode and one whole query episode, two tokens a step, at the longest
    horizon of any task the preset trains ICRT on (ML45's reach 500 steps)."""
    from icil_paper.sim.metaworld.tasks import METAWORLD_TASKS

    preset = get_preset(name)
    tasks = {*preset.data.robocasa_tasks, *preset.data.zero_shot_tasks}
    longest = max(METAWORLD_TASKS[t].horizon for t in tasks)
    assert preset.policies.icrt.max_seq_len >= 2 * 2 * longest
