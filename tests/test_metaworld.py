"""The Meta-World suite: task table, spaces, seeded layouts and scene distributions, the
goal slot, action mapping, the scripted experts, ML45, names and images."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import icil_paper.sim as sim
from icil_paper.registry import UnknownNameError
from icil_paper.sim.metaworld import (
    ALL_TASK_FAMILIES,
    FAMILIES,
    METAWORLD_SUITE,
    METAWORLD_TASKS,
    ML45_HELD_OUT,
    ML45_TRAIN,
    ROBOCASA_TASKS,
    TASK_FAMILIES,
    TASKS,
    family_of,
    make_metaworld_env,
    make_metaworld_expert,
    metaworld_problem,
)


@pytest.fixture(scope="module")
def drawer():
    if metaworld_problem():
        pytest.skip(metaworld_problem())
    env = make_metaworld_env("metaworld/drawer-open", obs="state", seed=0)
    yield env
    env.close()


def run_expert(env, seed: int, max_steps: int | None = None):
    """One expert episode; (success, steps, actions)."""
    expert = make_metaworld_expert(env.name)
    obs, info = env.reset(seed=seed)
    expert.reset(env, obs)
    actions = []
    for _ in range(max_steps or env.horizon):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "Constant(s) may be too high": Meta-World's own
            action = expert.act(obs)
        actions.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        assert terminated is info["success"]
        if terminated or truncated:
            break
    return info["success"], env.steps, np.array(actions)


# ---------------------------------------------------------------------------- task table
def test_the_task_table_covers_meta_world_with_the_families_first():
    assert len(TASKS) == len(set(TASKS)) == 50
    assert all(t.startswith("metaworld/") for t in TASKS)
    assert TASKS[:13] == ROBOCASA_TASKS and METAWORLD_SUITE.tasks == TASKS
    assert tuple(TASK_FAMILIES) == FAMILIES == tuple(ALL_TASK_FAMILIES)
    assert TASK_FAMILIES["Turning Levers"] == ("metaworld/faucet-open", "metaworld/faucet-close")
    assert TASK_FAMILIES["Insertion"] == ("metaworld/peg-insert-side", "metaworld/coffee-push")
    assert all(TASK_FAMILIES.values()) and not set(ROBOCASA_TASKS) & set(ML45_HELD_OUT)
    assert family_of("metaworld/door-lock") == "Twisting Knobs"
    assert family_of("metaworld/box-close") == "Open/Close Doors"
    assert family_of("metaworld/reach") is None
    for spec in METAWORLD_TASKS.values():
        assert spec.instruction and spec.instruction == spec.instruction.lower()
        assert 200 <= spec.horizon <= 500 and spec.name == f"metaworld/{spec.env_name}"
    # the suite's families reach the held-out tasks too (the zero-shot table's columns)
    assert sim.task_family("metaworld/hand-insert") == "Insertion"
    assert sim.task_family("metaworld/coffee-button") == "Pressing Buttons"


def test_the_zero_shot_split_is_ml45():
    assert len(ML45_TRAIN) == 45 and len(ML45_HELD_OUT) == 5
    assert not set(ML45_TRAIN) & set(ML45_HELD_OUT) and set(ML45_TRAIN) | set(ML45_HELD_OUT) \
        == set(TASKS)
    assert sim.get_suite("metaworld").zero_shot_split == {"train": ML45_TRAIN,
                                                          "held_out": ML45_HELD_OUT}


def test_unknown_names_say_what_was_meant():
    with pytest.raises(UnknownNameError, match="Did you mean 'metaworld/drawer-open'"):
        make_metaworld_env("metaworld/drawer-opn")
    with pytest.raises(UnknownNameError, match="Did you mean 'metaworld/drawer-open'"):
        sim.make_env("metaworld/drawer-opn")
    with pytest.raises(UnknownNameError, match="human"):
        make_metaworld_env("metaworld/drawer-open", scenes="humans")
    with pytest.raises(UnknownNameError, match="metaworld/peg-insert-side"):
        make_metaworld_expert("metaworld/peg-insertion-side")


def test_listing_the_suite_imports_no_simulator():
    code = ("import sys, icil_paper.sim as sim; assert len(sim.tasks_of('metaworld')) == 50; "
            "print(sorted({'metaworld', 'mujoco'} & set(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


# ---------------------------------------------------------------------------- the simulator
@pytest.mark.sim
@pytest.mark.skipif(metaworld_problem() is not None, reason=metaworld_problem() or "")
class TestSimulated:
    """What needs metaworld (skipped, with the reason, where it is not installed)."""

    def test_ml45_names_are_meta_worlds(self):
        from metaworld.env_dict import ML45_V3

        assert ML45_TRAIN == tuple(f"metaworld/{n.removesuffix('-v3')}"
                                   for n in ML45_V3["train"])
        assert ML45_HELD_OUT == tuple(f"metaworld/{n.removesuffix('-v3')}"
                                      for n in ML45_V3["test"])

    def test_every_task_has_its_policy_and_its_env(self):
        from metaworld.env_dict import ALL_V3_ENVIRONMENTS

        from icil_paper.sim.metaworld.env import POLICY_CLASSES

        assert {s.metaworld_id for s in METAWORLD_TASKS.values()} == set(ALL_V3_ENVIRONMENTS)
        rest = [f"metaworld/{n.removesuffix('-v3')}" for n in ALL_V3_ENVIRONMENTS]
        assert TASKS[13:] == tuple(t for t in rest if t not in ROBOCASA_TASKS)
        assert POLICY_CLASSES["metaworld/peg-insert-side"].__name__ == \
            "SawyerPegInsertionSideV3Policy"

    def test_gym_make_gives_the_documented_spaces(self):
        env = gym.make("icil_paper/metaworld-drawer-open-v0")
        raw = env.unwrapped
        assert raw.observation_space["proprio"].shape == (8,)
        assert raw.observation_space["object"].shape == (31,)
        assert raw.action_space == gym.spaces.Box(-1, 1, (7,), np.float32)
        assert raw.metadata["render_fps"] == METAWORLD_SUITE.control_freq == 80
        assert raw.control_dt == pytest.approx(raw.metaworld_env.dt)
        obs, info = env.reset(seed=3)
        assert obs in raw.observation_space and info["success"] is False
        assert np.allclose(obs["proprio"][:3], raw.eef_position(), atol=1e-6)
        for _ in range(5):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert obs in raw.observation_space and isinstance(reward, float)
            assert not terminated and not truncated
        env.close()

    def test_gymnasiums_checker_passes(self):
        from gymnasium.utils.env_checker import check_env

        env = make_metaworld_env("metaworld/button-press", seed=1, render_mode="rgb_array")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env)  # spaces, seeding, determinism, render, close twice
        assert not [w for w in caught if "infinity" in str(w.message)]

    def test_a_seed_is_a_layout(self, drawer):
        first, _ = drawer.reset(seed=11)
        layout = drawer.layout
        drawer.reset(seed=12)
        assert not np.allclose(drawer.layout, layout)
        again, _ = drawer.reset(seed=11)
        assert np.array_equal(drawer.layout, layout)
        for key in first:
            assert np.array_equal(first[key], again[key])
        space = drawer.metaworld_env._random_reset_space
        assert np.all(space.low <= layout) and np.all(layout <= space.high)

    def test_rejected_layouts_are_redrawn_reproducibly(self):
        """pick-place rejects a goal within 15 cm of the puck: the env draws again, and the
        same seed still gives the same layout (Meta-World's reset runs its layout code twice)."""
        env = make_metaworld_env("metaworld/pick-place")
        for seed in range(12):
            obs, _ = env.reset(seed=seed)
            puck, goal = obs["object"][:3], obs["object"][28:31]
            assert np.linalg.norm(puck[:2] - goal[:2]) >= 0.15
            assert np.array_equal(env.reset(seed=seed)[0]["object"], obs["object"])
        env.close()

    def test_the_goal_is_observed(self, drawer):
        obs, _ = drawer.reset(seed=4)
        goal = obs["object"][28:31]
        assert np.linalg.norm(goal) > 0.1
        assert np.allclose(goal, drawer.metaworld_env._target_pos, atol=1e-6)
        obs, *_ = drawer.step(np.zeros(7))
        assert np.allclose(obs["object"][28:31], goal)  # kept by Meta-World's clipping

    def test_the_observation_is_meta_worlds_state_split(self, drawer):
        drawer.reset(seed=5)
        obs, *_ = drawer.step(np.array([1, 0, 0, 0, 0, 0, -1.0]))
        raw = drawer.raw_observation()
        assert raw.shape == (39,)
        assert np.allclose(obs["proprio"], np.r_[raw[0:4], raw[18:22]], atol=1e-6)
        assert np.allclose(obs["object"], np.r_[raw[4:18], raw[22:36], raw[36:39]], atol=1e-6)
        assert obs["proprio"][0] > obs["proprio"][4]  # moved +x: now vs one step before

    def test_rotation_is_ignored_and_actions_are_clipped(self, drawer):
        def after(action):
            drawer.reset(seed=6)
            for _ in range(3):
                obs, *_ = drawer.step(np.asarray(action, np.float32))
            return obs["proprio"]

        base = after([0.5, -0.5, 0.3, 0, 0, 0, 1])
        assert np.array_equal(after([0.5, -0.5, 0.3, 1, -1, 0.7, 1]), base)
        assert np.array_equal(after([1, 0, 0, 0, 0, 0, 0]), after([3, 0, 0, 0, 0, 0, 0]))
        with pytest.raises(ValueError, match="7 entries"):
            drawer.step(np.zeros(4))

    def test_the_horizon_truncates(self):
        env = make_metaworld_env("metaworld/reach", horizon=3)
        env.reset(seed=0)
        flags = [env.step(np.zeros(7))[2:4] for _ in range(3)]
        assert flags == [(False, False), (False, False), (False, True)]
        env.close()

    def test_human_scenes_shift_the_hand_and_push_objects_outward(self):
        generated = make_metaworld_env("metaworld/pick-place")
        human = make_metaworld_env("metaworld/pick-place", scenes="human")
        spec = human.task_spec
        space = human.metaworld_env._random_reset_space
        free = space.high > space.low
        for seed in range(6):
            hand_g = generated.reset(seed=seed)[0]["proprio"][:3]
            hand_h = human.reset(seed=seed)[0]["proprio"][:3]
            assert 0.003 < np.abs(hand_h - hand_g).max() <= spec.hand_shift + 0.01
            u = (human.layout - space.low)[free] / (space.high - space.low)[free]
            assert np.all((u <= spec.outer) | (u >= 1 - spec.outer))
        generated.close()
        human.close()

    @pytest.mark.parametrize("task,scenes", [
        ("metaworld/drawer-open", "generated"), ("metaworld/drawer-open", "human"),
        ("metaworld/pick-place", "generated"), ("metaworld/pick-place", "human"),
        ("metaworld/peg-insert-side", "generated"), ("metaworld/dial-turn", "generated"),
        ("metaworld/faucet-open", "generated")])
    def test_the_expert_solves_unseen_layouts(self, task, scenes):
        env = make_metaworld_env(task, scenes=scenes)
        for seed in (1, 2, 3):
            success, steps, actions = run_expert(env, seed)
            assert success and steps < env.horizon, (task, scenes, seed)
            assert actions.shape == (steps, 7) and actions.dtype == np.float32
            assert np.all(np.abs(actions) <= 1.0) and not np.any(actions[:, 3:6])
        env.close()

    def test_expert_noise_is_seeded_by_the_episode(self, drawer):
        expert = make_metaworld_expert("metaworld/drawer-open", noise_std=0.3)

        def actions(seed):
            obs, _ = drawer.reset(seed=seed)
            expert.reset(drawer, obs)
            return np.stack([expert.act(obs) for _ in range(3)])

        assert np.array_equal(actions(8), actions(8)) and not np.array_equal(actions(8),
                                                                            actions(9))
        with pytest.raises(TypeError, match="MetaWorldEnv"):
            expert.reset(object(), None)

    def test_images_have_the_documented_shape(self):
        env = make_metaworld_env("metaworld/drawer-open", obs="rgbd", camera_size=32,
                                 render_mode="rgb_array")
        obs, _ = env.reset(seed=0)
        assert env.cameras == ("corner", "gripperPOV")
        assert obs["rgb"].shape == (2, 32, 32, 3) and obs["rgb"].dtype == np.uint8
        assert obs["depth"].shape == (2, 32, 32) and obs in env.observation_space
        assert obs["rgb"].std() > 10  # a scene, not a blank frame
        assert env.render().shape == (256, 256, 3)
        env.close()
        env.close()
