"""Every task env is a real `gymnasium.Env`: gymnasium's own checker, `gymnasium.make` by id,
gymnasium's wrappers, declared spaces that hold the observations, and seeding."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import icil_paper.sim as sim
from icil_paper.sim.base import TaskEnv

CHECKED = {"synthetic": "synthetic/task2", "kitchen": "kitchen/open_drawer",
           "kinova": "kinova/close_door", "maniskill": "maniskill/push_cube"}


def _skip_unless_available(suite: str) -> None:
    problem = sim.suite_unavailable(suite)
    if problem:
        pytest.skip(f"the {suite} suite cannot run here: {problem}")


@pytest.mark.parametrize("suite", [
    "synthetic", pytest.param("kitchen", marks=pytest.mark.sim),
    pytest.param("kinova", marks=pytest.mark.sim),
    pytest.param("maniskill", marks=[pytest.mark.sim, pytest.mark.slow])])
def test_gymnasium_env_checker_passes_for_every_suite(suite):
    _skip_unless_available(suite)
    env = gym.make(sim.gym_id(CHECKED[suite]))
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # spaces, seeding, determinism, render modes, close twice; for ManiSkill the render
            # check (a second env and SAPIEN's first picture, about 15 s) runs in
            # test_maniskill.py on the image env, which pays that start-up anyway
            check_env(env.unwrapped, skip_render_check=suite == "maniskill")
        if suite != "synthetic":  # finite bounds everywhere (the synthetic positions drift)
            assert not [w for w in caught if "infinity" in str(w.message)]
        raw = env.unwrapped
        assert isinstance(raw, TaskEnv)
        assert raw.metadata["render_fps"] == sim.get_suite(suite).control_freq
        assert raw.observation_space["proprio"].shape == (sim.obs_dims(suite)[0],)
        assert raw.observation_space["object"].shape == (sim.obs_dims(suite)[1],)
        assert raw.action_space == gym.spaces.Box(-1, 1, (7,), np.float32)
    finally:
        env.close()


def test_every_task_has_a_gymnasium_id():
    ids = sim.register_gym_envs()
    tasks = [t for s in sim.ALL_SUITES for t in sim.tasks_of(s)]
    assert ids == [sim.gym_id(t) for t in tasks] and len(set(ids)) == len(tasks)
    assert "icil_paper/kitchen-open_drawer-v0" in gym.registry
    assert gym.registry["icil_paper/maniskill-pick_cube-v0"].kwargs == {
        "name": "maniskill/pick_cube"}


def test_gymnasium_wrappers_apply_and_seeds_repeat_episodes():
    env = gym.make("icil_paper/synthetic-task0-v0", obs="rgbd", horizon=50)
    env = gym.wrappers.RecordEpisodeStatistics(gym.wrappers.TimeLimit(env, max_episode_steps=5))
    obs, info = env.reset(seed=7)
    assert obs in env.observation_space and obs["rgb"].shape == (1, 16, 16, 3)
    env.action_space.seed(0)
    actions = [env.action_space.sample() * 0.1 for _ in range(5)]  # too small to succeed
    for t, action in enumerate(actions):
        obs, reward, terminated, truncated, info = env.step(action)
        assert not terminated and truncated == (t == 4)  # TimeLimit cuts at 5 steps
    assert info["episode"]["l"] == 5 and info["episode"]["r"] == 0.0
    raw = env.unwrapped
    first = env.reset(seed=7)[0]
    again = env.reset(seed=7)[0]
    assert np.array_equal(first["proprio"], again["proprio"])  # a seed is an episode
    after_seed = [env.reset()[0]["proprio"] for _ in range(2)]
    env.reset(seed=7)
    assert np.array_equal(env.reset()[0]["proprio"], after_seed[0])  # gymnasium's seeding
    assert raw.np_random_seed == raw.seed
    env.close()


def test_unseeded_resets_start_with_the_constructor_seed():
    env = sim.make_env("synthetic/task0", seed=11)
    obs, _ = env.reset()
    assert env.seed == 11
    assert np.array_equal(obs["proprio"], sim.make_env("synthetic/task0").reset(seed=11)[0][
        "proprio"])
    env.reset()
    assert env.seed != 11
    env.close()
    env.close()  # closing twice is allowed


@pytest.mark.sim
def test_kitchen_env_spec_is_gymnasiums():
    _skip_unless_available("kitchen")
    env = gym.make("icil_paper/kitchen-open_drawer-v0", obs="rgbd", camera_size=16)
    raw = env.unwrapped
    assert raw.spec.id == "icil_paper/kitchen-open_drawer-v0"  # no longer the task's record
    assert raw.task_spec.name == "kitchen/open_drawer" and raw.cameras == (
        "agentview", "robot0_eye_in_hand")
    obs, _ = env.reset(seed=3)
    assert obs in raw.observation_space
    assert obs["rgb"].shape == (2, 16, 16, 3) and obs["depth"].shape == (2, 16, 16)
    assert env.render().shape == (256, 256, 3)
    env.close()
