"""The task registry: suite records, names, errors, lazy suites (with fake kitchen and Kinova
suites), splits, gymnasium ids."""

from __future__ import annotations

import numpy as np
import pytest

import fake_suite
import icil_paper.sim as sim
from icil_paper.data import splits
from icil_paper.registry import UnknownNameError

MANISKILL = ("maniskill/pick_cube", "maniskill/push_cube", "maniskill/stack_cube")


@pytest.fixture
def fake_kitchen(monkeypatch):
    fake_suite.use(monkeypatch)


@pytest.fixture
def broken_kitchen(monkeypatch):
    fake_suite.use(monkeypatch, broken=True)  # registry entries that name no record


def test_maniskill_tasks_are_registered_without_importing_the_simulator():
    assert set(MANISKILL) <= set(sim.TASKS)
    assert sim.obs_dims("maniskill") == (9, 21)
    assert sim.suite_of("maniskill/stack_cube") == "maniskill"
    assert sim.tasks_of("maniskill") == MANISKILL


def test_every_suite_record_is_complete_and_consistent():
    from icil_paper.sim.suite import Suite

    assert sim.SUITES == ("metaworld", "kitchen", "kinova", "maniskill")  # studies, notebooks
    assert set(sim.ALL_SUITES) == set(sim.SUITES) | {"synthetic"}
    for name in sim.ALL_SUITES:
        record = sim.get_suite(name)
        assert isinstance(record, Suite) and record.name == name
        assert record.tasks and all(t.startswith(name + "/") for t in record.tasks)
        assert all(sim.suite_of(t) == name for t in record.tasks)
        assert sim.obs_dims(name) == record.obs_dims and record.control_freq > 0
        if record.object_position is not None:
            start, stop = record.object_position
            assert 0 <= start < stop <= record.obs_dims[1]
        assert sim.object_position(record.tasks[0]) == record.object_position
    assert not any(t.startswith("synthetic/") for t in sim.TASKS)  # listed separately
    assert sim.suite_of("synthetic/task3") == "synthetic"
    assert sim.object_position("kinova/open_door") == (1, 4)
    assert sim.object_position("maniskill/pick_cube") == (0, 3)
    assert sim.object_position("elsewhere/task") is None


def test_a_suite_is_one_registry_line(monkeypatch):
    """A new suite needs only its record and one registry entry; every function then knows it."""
    from icil_paper.sim.suite import Suite

    extra = Suite(name="extra", tasks=("extra/reach",), obs_dims=(9, 6), control_freq=10,
                  make_env=fake_suite.make_env, make_expert=fake_suite.make_expert)
    monkeypatch.setattr(sim, "ALL_SUITES", (*sim.ALL_SUITES, "extra"))
    monkeypatch.setattr(sim, "SUITE_REGISTRY", {**sim.SUITE_REGISTRY, "extra": lambda: extra})
    assert sim.suite_of("extra/reach") == "extra" and sim.tasks_of("extra") == ("extra/reach",)
    env = sim.make_env("extra/reach", seed=2)
    assert env.reset()[0]["proprio"].shape == (9,) and env.seed == 2
    assert sim.suite_unavailable("extra") is None and sim.object_position("extra/reach") is None


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(UnknownNameError, match="maniskill/pick_cube") as err:
        sim.make_env("maniskill/pick_cub")
    assert "Did you mean 'maniskill/pick_cube'" in str(err.value)
    with pytest.raises(UnknownNameError, match="rgbd"):
        sim.make_env("maniskill/pick_cube", obs="depth")
    with pytest.raises(UnknownNameError, match="metaworld, kitchen, kinova, maniskill, synthetic"):
        sim.obs_dims("robocasa")
    with pytest.raises(UnknownNameError, match="synthetic/task0"):
        sim.make_env("synthetic/task99")
    with pytest.raises(AttributeError):
        sim.NOT_A_THING  # noqa: B018


def test_fake_kitchen_suite_is_dispatched(fake_kitchen):
    tasks = sim.TASKS
    meta = sim.tasks_of("metaworld")
    assert tasks[:len(meta)] == meta and len(meta) == 50
    assert tasks[len(meta):len(meta) + 4] == fake_suite.KITCHEN + fake_suite.KINOVA
    assert tasks[-3:] == MANISKILL
    assert sim.suite_of("kinova/reach_a") == "kinova"
    assert sim.obs_dims("kitchen") == sim.obs_dims("kinova") == fake_suite.OBS_DIMS
    env = sim.make_env("kitchen/reach_b", obs="rgb", seed=7, horizon=12)
    assert (env.name, env.horizon, env.obs_kind) == ("kitchen/reach_b", 12, "rgb")
    obs, info = env.reset()
    assert env.seed == 7 and obs["rgb"].shape == (1, 8, 8, 3)
    expert = sim.make_expert("kitchen/reach_b")
    expert.reset(env, obs)
    for _ in range(env.horizon):
        obs, _, terminated, truncated, info = env.step(expert.act(obs))
        if terminated or truncated:
            break
    assert info["success"]
    with pytest.raises(UnknownNameError, match="kitchen/reach_a"):
        sim.make_env("kitchen/open_drawer")


def test_unfinished_kitchen_package_leaves_maniskill_working(broken_kitchen):
    assert sim.TASKS == sim.tasks_of("metaworld") + MANISKILL
    assert "has no attribute 'NO_SUCH_RECORD'" in sim.suite_unavailable("kitchen")
    assert sim.suite_unavailable("maniskill") is None
    assert sim.tasks_of("kinova") == () and sim.object_position("kitchen/open_drawer") is None
    with pytest.raises(sim.SuiteUnavailable, match="kitchen suite could not be loaded"):
        sim.make_env("kitchen/open_drawer")
    with pytest.raises(sim.SuiteUnavailable):
        sim.obs_dims("kinova")


def test_zero_shot_and_sim_to_real_splits(fake_kitchen):
    with pytest.raises(ValueError, match="kitchen suite defines no zero-shot split"):
        splits.zero_shot_split("kitchen")  # as the real one: Table VII's is Meta-World's
    assert splits.sim_to_real_pairs() == {"kinova/reach_a": "kitchen/reach_a"}
    assert splits._normalize_split((("a",), ("b",))) == (("a",), ("b",))
    with pytest.raises(ValueError, match="keys"):
        splits._normalize_split({"foo": ()})


def test_action_conversion_to_maniskill_controller():
    from scipy.spatial.transform import Rotation

    from icil_paper.sim.maniskill.env import ROT_SCALE, policy_to_maniskill_action

    a = np.array([0.5, -1.5, 0.2, 0.0, 0.0, 0.3, 1.0])
    out = policy_to_maniskill_action(a)
    assert np.allclose(out[:3], [0.5, -1.0, 0.2])  # clipped to the box
    assert out[6] == -1.0  # the suite's +1 (close) is ManiSkill's -1
    # ManiSkill composes XYZ Euler angles of (input * rot_lower), rot_lower = -0.1
    euler = out[3:6] * -ROT_SCALE
    rotvec = Rotation.from_euler("XYZ", euler).as_rotvec()
    assert np.allclose(rotvec, [0, 0, 0.3 * ROT_SCALE], atol=1e-6)
    big = policy_to_maniskill_action(np.array([0, 0, 0, 1, 1, 1, 0.0]))
    assert np.isclose(np.linalg.norm(Rotation.from_euler("XYZ", big[3:6] * -ROT_SCALE)
                                     .as_rotvec()), ROT_SCALE)  # norm clipped to 0.1 rad
    with pytest.raises(ValueError, match="7 entries"):
        policy_to_maniskill_action(np.zeros(6))


def test_rendering_check_reports_a_reason_or_nothing():
    from icil_paper.sim.maniskill import env

    reason = env.vulkan_skip_reason()
    assert (reason == "") == env.vulkan_available()
    assert "lavapipe" in env.LAVAPIPE_HOWTO and "bookworm-backports" in \
        env.LAVAPIPE_HOWTO
