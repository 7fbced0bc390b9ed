"""Cell costs: the phase clock, a grid worker that keeps its environments from cell to cell
(the same records as building them afresh, and no env built the second time), and the cost
benchmark's cells taken from the tables' plan."""

from __future__ import annotations

import time

import pytest

from icil_paper.config import get_preset
from icil_paper.config_data import to_dict
from icil_paper.eval import rollouts
from icil_paper.paper.table_ii import maniskill_settings
from icil_paper.records import eval_record
from icil_paper.results import ResultsStore
from icil_paper.runspec import EvalSpec, run_spec
from icil_paper.timing import phase, recording

TASKS = ["kitchen/open_drawer", "kitchen/close_drawer"]


def test_phases_are_measured_only_while_recording():
    with phase("outside"):
        time.sleep(0.01)
    with recording() as phases:
        for _ in range(3):
            with phase("a"):
                time.sleep(0.01)
        with phase("b"):
            pass
    assert set(phases.wall) == {"a", "b"}  # nothing from before the recording
    assert phases.count == {"a": 3, "b": 1}
    assert 0.03 <= phases.wall["a"] < 1.0 and phases.wall["b"] < phases.wall["a"]
    with phase("after"):
        pass
    assert "after" not in phases.wall


def _eval_rows(store: ResultsStore, run, evals) -> list[list[dict]]:
    """Each evaluation's per-episode rows, without their timings."""
    out = []
    for ev in evals:
        rows = store.get(*eval_record(run, ev))["metrics"]["per_episode"]
        out.append([{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows])
    return out


def test_a_worker_that_keeps_its_envs_writes_the_same_records(tmp_path, monkeypatch):
    from icil_paper.tables.cells import run_cell

    preset = get_preset("smoke")
    run = run_spec(preset, "icrt", "bin", tasks=TASKS)
    evals = [EvalSpec(task, episodes=2, max_steps=8) for task in TASKS]
    second = run.replace(seed=run.seed + 1)

    def cell(spec) -> dict:
        with recording() as phases:
            run_cell("smoke", spec.to_dict(), [to_dict(e) for e in evals], [])
        return dict(phases.count)

    rollouts.worker_state().close()
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "kept-runs"))
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "kept"))
    assert cell(run)["eval.env_build"] == len(TASKS)
    counts = cell(second)  # the next cell of the same worker process
    assert "eval.env_build" not in counts and counts["eval.sim"] > 0
    kept = _eval_rows(ResultsStore("smoke"), second, evals)

    rollouts.worker_state().close()  # a fresh worker: every env built anew
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "fresh-runs"))
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "fresh"))
    assert cell(second)["eval.env_build"] == len(TASKS)
    assert _eval_rows(ResultsStore("smoke"), second, evals) == kept
    rollouts.worker_state().close()


def test_the_kept_envs_are_capped_and_a_call_keeps_the_ones_it_uses(monkeypatch):
    from icil_paper.sim.synthetic import make_synthetic_env

    rollouts.worker_state().close()
    monkeypatch.setattr(rollouts, "KEPT_ENVS", 2)
    from tools.bench.eval import ZeroActions

    policy = ZeroActions()

    def episodes(tasks):
        return [rollouts.Episode(spec=i, task=f"synthetic/task{t}", index=0, seed=i,
                                 max_steps=3) for i, t in enumerate(tasks)]

    def kept():
        return sorted(key[3] for key in rollouts.worker_state().envs)

    rollouts.run_episodes(policy, episodes([0, 1]), env_factory=make_synthetic_env,
                          progress=False, keep_envs=True)
    assert kept() == ["synthetic/task0", "synthetic/task1"]
    before = rollouts.worker_state().envs[next(iter(rollouts.worker_state().envs))][0]
    rollouts.run_episodes(policy, episodes([0, 2]), env_factory=make_synthetic_env,
                          progress=False, keep_envs=True)
    assert kept() == ["synthetic/task0", "synthetic/task2"]  # task1's, unused, was closed
    assert rollouts.worker_state().envs[next(iter(rollouts.worker_state().envs))][0] is before
    rollouts.worker_state().close()


@pytest.mark.parametrize("kind", ["icrt_lipvq", "bc_transformer", "act_maniskill",
                                  "kinova_eval"])
def test_the_benchmark_cells_are_the_reference_tables_cells(kind):
    from icil_paper.paper import table_spec
    from tools.bench.cells import kind_cell, shortened

    preset = get_preset("reference")
    run, evals = kind_cell(preset, kind)
    table = {"act_maniskill": "II", "kinova_eval": "V"}.get(kind, "I")
    units = [u for u in table_spec(preset, table).units() if u.run.key() == run.key()]
    assert units and {u.eval.task for u in units if u.eval} == {ev.task for ev in evals}
    assert run.train.steps == (maniskill_settings(preset)[1] if kind == "act_maniskill"
                               else preset.train.steps)
    short, short_evals = shortened(run, evals, 0.1)
    assert short.train.steps == round(run.train.steps * 0.1)
    assert all(e.episodes == max(1, round(ev.episodes * 0.1))
               for e, ev in zip(short_evals, evals, strict=True))
    assert short.policy == run.policy and short.data == run.data
