"""Table VI's cross-dataset shift: the kitchen suite's `human` scene distribution, selected by
`make_env(..., scenes=)`, by `EvalSpec.scenes` through the rollout engine, and by the `human`
source when it generates its demonstrations; Table VI evaluates every row on it; old data
sets of the human source are not reused; the per-row change from Table I is paired by seed.

The plumbing is tested on a simulator-free reach suite whose `human` scenes move the goal;
the kitchen suite's own layouts need robosuite (`sim` tests)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import fake_suite
import icil_paper.sim as sim
from icil_paper.config import get_preset
from icil_paper.data import demo_path, ensure_demos, file_info, load_demos, write_demos
from icil_paper.data.generate import GENERATOR, OLDER_GENERATORS, outdated
from icil_paper.data.sources import source_env_options
from icil_paper.eval import evaluate_many, plan_episodes
from icil_paper.eval.rollouts import EnvSetup, Episode, WorkerState
from icil_paper.paper import table_spec
from icil_paper.paper.table_i import TABLE_I_ROWS
from icil_paper.paper.table_vi import shift_counts, shift_frame, shift_rows
from icil_paper.registry import UnknownNameError
from icil_paper.runspec import SCENE_DISTRIBUTIONS, EvalSpec, eval_key
from icil_paper.stats import Estimate
from icil_paper.tables.assemble import EntryResult, TableResult
from icil_paper.tables.definitions import label
from icil_paper.tables.spec import Entry, Row, TableSpec

TASK = "kitchen/reach_a"
HUMAN_GOAL_SHIFT = np.array([0.05, -0.04, 0.0])


def _robosuite_problem() -> str | None:
    from icil_paper.sim.kitchen import robosuite_problem

    return robosuite_problem()


needs_robosuite = pytest.mark.skipif(_robosuite_problem() is not None,
                                     reason=str(_robosuite_problem()))


# --------------------------------------------------------------------------- a shifted fake suite
class ShiftedReachEnv(fake_suite.ReachEnv):
    """The fake reach task with two scene distributions: `human` moves the goal."""

    def __init__(self, name, obs="state", seed=0, scenes="generated", **options):
        if scenes not in SCENE_DISTRIBUTIONS:
            raise ValueError(f"unknown scene distribution {scenes!r}")
        super().__init__(name, obs, seed, **options)
        self.scenes = scenes

    def reset(self, seed=None, options=None):
        _, info = super().reset(seed, options)
        if self.scenes == "human":
            self.goal = self.goal + HUMAN_GOAL_SHIFT
        return self._obs(), info


def _make_shifted(name, obs="state", seed=0, **options):
    return ShiftedReachEnv(name, obs, seed, **options)


SHIFTED_KITCHEN = dataclasses.replace(fake_suite.KITCHEN_SUITE, make_env=_make_shifted,
                                      scenes=SCENE_DISTRIBUTIONS)


@pytest.fixture
def shifted_kitchen(monkeypatch, tmp_path):
    monkeypatch.setattr(sim, "SUITE_REGISTRY", {**fake_suite.registry(),
                                                "kitchen": lambda: SHIFTED_KITCHEN})
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    return tmp_path / "data"


# --------------------------------------------------------------------------- names and specs
def test_the_scene_names_agree_and_a_wrong_one_is_refused():
    from icil_paper.sim.kitchen import KINOVA_SUITE, KITCHEN_SUITE
    from icil_paper.sim.kitchen import SCENE_DISTRIBUTIONS as KITCHEN_SCENES

    assert SCENE_DISTRIBUTIONS == KITCHEN_SCENES == KITCHEN_SUITE.scenes
    assert KINOVA_SUITE.scenes == ()  # the Kinova stand-in keeps its one distribution
    assert EvalSpec("kitchen/open_drawer", 2).scenes == "generated"
    with pytest.raises(UnknownNameError, match="EvalSpec.scenes"):
        EvalSpec("kitchen/open_drawer", 2, scenes="humans")


def test_table_vi_evaluates_every_row_on_the_human_scenes():
    preset = get_preset("smoke")
    t1, t6 = table_spec(preset, "I"), table_spec(preset, "VI")
    for policy, tokenizer in TABLE_I_ROWS:
        name = label(policy, tokenizer)
        u1, u6 = t1.row(name).entries["avg"].units, t6.row(name).entries["avg"].units
        assert [u.run.key() for u in u1] == [u.run.key() for u in u6], name  # same policies
        assert {u.eval.scenes for u in u1} == {"generated"}, name
        assert {u.eval.scenes for u in u6} == {"human"}, name
        assert not {eval_key(u.run, u.eval) for u in u1} & {eval_key(u.run, u.eval)
                                                             for u in u6}, name
        for a, b in zip(u1, u6, strict=True):  # the same episodes, seeds and limits
            assert (a.eval.task, a.eval.seed, a.eval.episodes, a.eval.max_steps) == (
                b.eval.task, b.eval.seed, b.eval.episodes, b.eval.max_steps)
        sources = {u.eval.prompt_source for u in u6}
        assert sources == ({"human"} if policy == "icrt" else {"generated"}), name
    bc = [u.eval for u in t6.row("bc_transformer").entries["avg"].units]
    assert bc[0] != dataclasses.replace(bc[0], scenes="generated")
    assert "human-like scene distribution" in t6.note and "every row" in t6.note


# --------------------------------------------------------------------------- the rollout engine
def test_episodes_carry_their_scenes_and_each_gets_its_own_env(shifted_kitchen):
    human = EvalSpec(TASK, 2, scenes="human")
    generated = EvalSpec(TASK, 2)
    assert {ep.env_options for ep in plan_episodes(human)} == {(("scenes", "human"),)}
    assert {ep.env_options for ep in plan_episodes(generated)} == {()}
    state = WorkerState()
    episodes = [Episode(0, TASK, 0, 5, env_options=(("scenes", "human"),)),
                Episode(1, TASK, 0, 5)]
    try:
        envs = state.envs_for(EnvSetup(), episodes)
        assert [e.scenes for e in envs] == ["human", "generated"]
        again = state.envs_for(EnvSetup(), episodes)
        assert all(a is b for a, b in zip(envs, again, strict=True))  # built once, kept
        goals = [e.reset(seed=5)[0]["object"][:3] for e in envs]
        assert np.allclose(goals[0] - goals[1], HUMAN_GOAL_SHIFT, atol=1e-6)
    finally:
        state.close()


class _Recorder:
    """A zero-action policy that records the goal each episode starts with."""

    name, uses_prompt, action_dim = "recorder", False, 7
    config = type("Config", (), {"prompt_demos": 1})()
    obs_spec = type("ObsSpec", (), {"lowdim_dim": 0, "image": None, "depth": False})()

    def reset_batch(self, prompts, instructions=None):
        self.rows = len(prompts)

    def select_actions(self, obs, rows):
        return np.zeros((len(rows), 7), np.float32)


def test_an_evaluation_on_the_human_scenes_builds_its_envs_on_them(shifted_kitchen):
    seen = []

    def factory(task, obs="state", seed=0, **options):
        seen.append(options.get("scenes", "generated"))
        return _make_shifted(task, obs, seed, **options)

    specs = [EvalSpec(TASK, 1, max_steps=2, scenes="human"), EvalSpec(TASK, 1, max_steps=2)]
    results = evaluate_many(_Recorder(), specs, progress=False, env_factory=factory)
    assert sorted(seen) == ["generated", "human"] and len(results) == 2


def test_a_suite_without_scene_distributions_refuses_the_human_scenes(monkeypatch):
    from icil_paper.sim.synthetic import SYNTHETIC_SUITE

    assert sim.scene_distributions("synthetic/task0") == ()
    assert source_env_options("human", "synthetic/task0") == {}
    with pytest.raises(ValueError, match="no 'human' scene distribution"):
        evaluate_many(_Recorder(), [EvalSpec("synthetic/task0", 1, scenes="human")], progress=False)
    assert SYNTHETIC_SUITE.scenes == ()


# --------------------------------------------------------------------------- data sets
def test_the_human_source_generates_its_demos_on_the_human_scenes(shifted_kitchen):
    assert source_env_options("human", TASK) == {"scenes": "human"}
    assert source_env_options("generated", TASK) == {}
    path = ensure_demos("smoke", TASK, "human", n=2, workers=1, progress=False, seed=7)
    info = file_info(path)
    assert info["scenes"] == "human" and info["generator"] == GENERATOR
    assert info["env_args"]["env_kwargs"]["scenes"] == "human"  # the env can be rebuilt
    generated = file_info(ensure_demos("smoke", TASK, "generated", n=1, workers=1,
                                       progress=False, seed=7))
    assert generated["scenes"] == "generated"
    assert "scenes" not in generated["env_args"]["env_kwargs"]  # built as before
    for demo in load_demos(path):
        on_human = ShiftedReachEnv(TASK, scenes="human").reset(seed=demo.seed)[0]
        on_generated = ShiftedReachEnv(TASK).reset(seed=demo.seed)[0]
        assert np.allclose(demo.obs["object"][0, :3], on_human["object"][:3])
        assert not np.allclose(demo.obs["object"][0, :3], on_generated["object"][:3])


def _old_file(path, source: str, seed: int) -> None:
    """A data set as generator 1 wrote it (no `scenes` attribute, the same scenes for both
    sources)."""
    env = ShiftedReachEnv(TASK)
    obs, _ = env.reset(seed=seed)
    from icil_paper.data.hdf5 import Demo

    demo = Demo(actions=np.zeros((3, 7), np.float32),
                obs={k: np.stack([v] * 3) for k, v in obs.items()}, task=TASK, source=source,
                instruction=env.instruction, seed=seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    attrs = {"task": TASK, "source": source, "obs_kind": "state", "base_seed": 7,
             "generator": "icil_paper.data.generate/1"}
    write_demos(path, [demo], file_attrs=attrs, names=["demo_0"])


def test_an_old_human_data_set_is_set_aside_and_made_again(shifted_kitchen, monkeypatch):
    assert "human" not in OLDER_GENERATORS["icil_paper.data.generate/1"]
    # a generator that made the generated source's files as this one does (1 did, until
    # the suite's second version made every older file outdated)
    monkeypatch.setitem(OLDER_GENERATORS, "icil_paper.data.generate/1", ("generated",))
    human = demo_path("smoke", TASK, "human")
    _old_file(human, "human", seed=123)
    old = human.read_bytes()
    assert outdated(file_info(human), "human") is not None
    with pytest.warns(UserWarning, match="generate/1.*made human demonstrations differently"):
        ensure_demos("smoke", TASK, "human", n=1, workers=1, progress=False, seed=7)
    [aside] = human.parent.glob("human.hdf5.outdated-*")
    assert aside.read_bytes() == old  # kept, never deleted
    assert file_info(human)["generator"] == GENERATOR
    assert load_demos(human)[0].seed != 123
    # the generated source's files of such a generator are reused
    generated = demo_path("smoke", TASK, "generated")
    _old_file(generated, "generated", seed=321)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ensure_demos("smoke", TASK, "generated", n=1, workers=1, progress=False, seed=7)
    assert load_demos(generated)[0].seed == 321


def test_a_data_set_of_other_scenes_is_refused(shifted_kitchen):
    path = ensure_demos("smoke", TASK, "human", n=1, workers=1, progress=False, seed=7)
    import h5py

    with h5py.File(path, "r+") as f:
        f["data"].attrs["scenes"] = "generated"
    from icil_paper.data import DatasetError

    with pytest.raises(DatasetError, match="scenes='generated'"):
        ensure_demos("smoke", TASK, "human", n=1, workers=1, progress=False, seed=7)
    with pytest.raises(ValueError, match="follows its source"):
        ensure_demos("smoke", TASK, "generated", n=1, workers=1, progress=False, seed=7,
                     scenes="human")


# --------------------------------------------------------------------------- the kitchen suite
@needs_robosuite
@pytest.mark.sim
def test_kitchen_human_scenes_differ_from_generated_and_repeat_per_seed():
    from icil_paper.sim.kitchen import make_kitchen_env

    envs = {"generated": make_kitchen_env("kitchen/open_drawer"),
            "human": make_kitchen_env("kitchen/open_drawer", scenes="human"),
            "human again": make_kitchen_env("kitchen/open_drawer", scenes="human")}
    try:
        layout = envs["human"].scene.layouts["human"]
        for seed in (0, 1, 2):
            obs = {k: env.reset(seed=seed)[0]["object"] for k, env in envs.items()}
            assert np.array_equal(obs["human"], obs["human again"])  # deterministic per seed
            base = obs["human"][8:11]                               # the fixture's base
            assert not np.allclose(base, obs["generated"][8:11], atol=1e-3)
            assert layout.x[0] <= base[0] <= layout.x[1]
            assert layout.y[0] <= base[1] <= layout.y[1]
        other = envs["human"].reset(seed=3)[0]["object"]
        assert not np.allclose(other[8:11], obs["human"][8:11])  # and differs between seeds
    finally:
        for env in envs.values():
            env.close()
    with pytest.raises(ValueError, match="scene distribution"):
        make_kitchen_env("kitchen/open_drawer", scenes="humans")


@needs_robosuite
@pytest.mark.sim
def test_the_expert_solves_a_human_scene():
    from icil_paper.data.sources import expert_rollout, make_source
    from icil_paper.sim.kitchen import make_kitchen_env

    env = make_kitchen_env("kitchen/close_drawer", scenes="human")
    try:
        demo, ok = expert_rollout(env, make_source("human", "kitchen/close_drawer"), seed=11,
                                  source="human", record_states=False)
    finally:
        env.close()
    assert ok and len(demo) > 0


# --------------------------------------------------------------------------- Table I vs Table VI
def _result(table_id: str, rows: dict[str, np.ndarray]) -> TableResult:
    spec = TableSpec(table_id, table_id, ("avg",),
                     tuple(Row(r, {"avg": Entry(())}) for r in rows))
    cells = {(r, "avg"): EntryResult(Estimate(float(x.mean()), 0.0, 1.0, len(x), "test"), x, 0)
             for r, x in rows.items()}
    return TableResult(spec, cells, "smoke")


def test_the_shift_is_paired_by_training_seed():
    # three seeds of very different skill (0.3, 0.55, 0.8), each losing 0.2 to the shift
    wins = np.array([18, 33, 48])
    episode = np.arange(60)
    before = np.broadcast_to(episode < wins[:, None, None], (3, 3, 60)).copy()
    after = np.broadcast_to(episode < wins[:, None, None] - 12, (3, 3, 60)).copy()
    one_seed = before[:1]
    i = _result("I", {"bc_transformer": before, "icrt+lipvq": before, "act": one_seed})
    vi = _result("VI", {"bc_transformer": after, "icrt+lipvq": before, "act": one_seed})
    rows = {r["row"]: r for r in shift_rows(i, vi)}
    lowered = rows["bc_transformer"]
    assert lowered["estimate"].value < 0 and lowered["verdict"] == "holds"
    assert "paired t" in lowered["estimate"].method
    # unpaired (Welch) the seeds' spread would swamp the same difference
    from icil_paper import stats

    assert stats.verdict(stats.paired_difference(after, before), -1) == "inconclusive"
    assert rows["icrt+lipvq"]["verdict"] == "inconclusive"  # no change
    assert rows["act"]["verdict"] == "too few seeds"
    frame = shift_frame(i, vi)
    assert list(frame.index) == ["bc_transformer", "icrt+lipvq", "act"]
    assert frame.loc["bc_transformer", "lower on the human scenes?"] == "holds"
    assert frame.loc["bc_transformer", "paper Table VI - Table I"].startswith("-")
    counts = shift_counts(i, vi)
    assert counts["holds"] == 1 and (counts["measured"], counts["rows"]) == (3, 3)
    missing = _result("VI", {"bc_transformer": after})
    missing.entries[("bc_transformer", "avg")] = EntryResult(None, None, 3)
    assert shift_rows(i, missing)[0]["verdict"] == "not run"
    with pytest.raises(ValueError, match="same policies and episodes"):
        shift_rows(i, _result("VI", {"bc_transformer": after[:2]}))
