"""The reproduction runner and the studies it shares with the chapters."""

from __future__ import annotations

import numpy as np
import pytest

from icil_paper import reproduce
from icil_paper.config import get_preset
from icil_paper.registry import UnknownNameError
from icil_paper.results import ResultsStore
from icil_paper.stages import Stage

CALLS: list[tuple[str, bool]] = []


def _counting_stage(preset, store, force):
    CALLS.append((preset.name, force))
    store.run("probe", "one", {"x": 1}, lambda: {"value": float(np.random.rand())},
              seed=preset.seed, force=force)


def _never_called(preset, store, force):
    raise AssertionError("a stage that was not chosen ran")


@pytest.fixture
def probe_stages(monkeypatch):
    CALLS.clear()
    stages = (Stage("probe", "a test stage", _counting_stage),
              Stage("other", "never chosen here", _never_called))
    monkeypatch.setattr(reproduce, "STAGES", stages)


def test_stages_run_in_order_and_results_are_reused(probe_stages):
    preset = get_preset("smoke")
    reproduce.run_stages(preset, ["probe"])
    first = ResultsStore("smoke").records("probe")[0]["metrics"]["value"]
    reproduce.run_stages(preset, ["probe"])  # stored: loaded, not recomputed
    assert ResultsStore("smoke").records("probe")[0]["metrics"]["value"] == first
    reproduce.run_stages(preset, ["probe"], force=True)
    assert CALLS == [("smoke", False), ("smoke", False), ("smoke", True)]
    # every stage is seeded the same way, so a forced rerun gives the same number
    assert ResultsStore("smoke").records("probe")[0]["metrics"]["value"] == first


def test_unknown_stage_is_an_error_listing_the_stages(probe_stages):
    with pytest.raises(UnknownNameError, match="probe, other"):
        reproduce.run_stages(get_preset("smoke"), ["probes"])


def test_every_stage_names_a_function_and_each_table_stage_its_table():
    for stage in reproduce.STAGES:
        assert callable(stage.run), stage.name
    tables = [s for s in reproduce.STAGES if s.name.startswith("table-")]
    assert [s.run.__doc__ for s in tables] == [
        f"Compute every missing cell of table {s.name.removeprefix('table-')}." for s in tables]


@pytest.mark.sim
def test_tokenizer_trajectories_come_from_held_out_demos():
    from icil_paper.book.studies import tokenizer_trajectories

    preset = get_preset("smoke").replace(
        data={"robocasa_tasks": ("kitchen/open_drawer",), "maniskill_tasks": (),
              "demos_per_task": 3})
    train, test, described = tokenizer_trajectories(preset)
    assert (len(train), len(test)) == (2, 1)  # a fifth of 3, at least one, held out
    assert all(t.ndim == 2 and t.shape[1] == 7 and t.dtype == np.float32 for t in train + test)
    assert not any(np.array_equal(a, b) for a in train for b in test)
    assert described["tasks"] == ["kitchen/open_drawer"] and described["kind"] == "demos"
    synthetic = preset.replace(tokenizer_study={"trajectories": "synthetic"})
    train_s, test_s, described_s = tokenizer_trajectories(synthetic)
    assert described_s["kind"] == "synthetic"
    assert len(train_s) == synthetic.tokenizer_study.n_trajectories
    with pytest.raises(UnknownNameError, match="demos, synthetic"):
        tokenizer_trajectories(preset.replace(tokenizer_study={"trajectories": "recorded"}))


def test_table_cells_ask_for_the_gpus_given_on_the_command_line(monkeypatch):
    """`reproduce --gpus-per-cell 1` reaches every table cell (Ray schedules by it); a
    negative count is refused before anything runs."""
    from icil_paper.tables import cells

    seen = []
    monkeypatch.setattr(cells, "ensure_data", lambda *a, **k: None)
    monkeypatch.setattr(cells, "run_jobs",
                        lambda fn, jobs, **kw: seen.extend((job, kw["gpus"]) for job in jobs) or {})
    monkeypatch.setattr(reproduce, "GRID", dict(reproduce.GRID))
    assert reproduce.main(["--preset", "smoke", "--stages", "table-V",
                           "--gpus-per-cell", "1"]) == 0
    assert seen and {gpus for _, gpus in seen} == {1.0}
    with pytest.raises(SystemExit) as exc:
        reproduce.main(["--preset", "smoke", "--stages", "table-V", "--gpus-per-cell", "-1"])
    assert exc.value.code == 2


def test_the_first_table_stage_computes_every_chosen_tables_cells(monkeypatch):
    """Each policy is trained once and evaluated for every chosen table in its own cell, so
    no later stage needs a checkpoint of an earlier sitting."""
    calls = []
    monkeypatch.setattr(reproduce, "run_tables", lambda preset, ids, **kw: calls.append(list(ids)))
    reproduce.run_stages(get_preset("smoke"), ["table-I", "table-V", "claims"])
    assert calls == [["I", "V"], ["I", "V"]]  # the second finds every record done
    reproduce.run_stages(get_preset("smoke"), ["table-V"])
    assert calls[-1] == ["V"]


def test_chapter_02s_run_is_a_table_stage_where_its_study_stood():
    """`table-icrt` runs chapter 02's table through the grid, after the showcase and before
    the chapters' own studies, as a block of its own: the paper's table stages after the
    studies still compute their cells together."""
    names = [s.name for s in reproduce.STAGES]
    assert "icrt" not in names
    at = names.index("table-icrt")
    assert names[at - 1:at + 2] == ["showcase", "table-icrt", "lipschitz"]
    assert reproduce.STAGES[at].run.__doc__ == "Compute every missing cell of table icrt."
    papers = [n.removeprefix("table-") for n in names[at + 1:] if n.startswith("table-")]
    assert reproduce.table_blocks(names) == [["icrt"], papers]
    assert reproduce.table_blocks(["table-icrt", "table-I", "claims", "table-V"]) == [
        ["icrt", "I"], ["V"]]


def test_a_table_stage_computes_the_tables_of_its_block_only(monkeypatch):
    calls = []
    monkeypatch.setattr(reproduce, "run_tables", lambda preset, ids, **kw: calls.append(list(ids)))
    table = {s.name: s for s in reproduce.STAGES}
    monkeypatch.setattr(reproduce, "STAGES", (
        table["table-icrt"], Stage("probe", "a study between", _counting_stage),
        table["table-I"], table["table-V"]))
    reproduce.run_stages(get_preset("smoke"))
    assert calls == [["icrt"], ["I", "V"], ["I", "V"]]
