"""A simulator-free stand-in for the kitchen package, for the registry and data tests.

A point "end effector" reaches a goal; it has the project's env interface (obs dict with
proprio (9,) and object (6,), 7-D actions, `info["success"]`), so the registry, the sources and
the data tooling can be tested in milliseconds. Seeds ending in 3 put the goal out of
reach (first attempts only: seeds below 1e6 ending in 3), so the expert fails there and
generation must move on to the demo's next seed.
"""

from __future__ import annotations

import sys
import time
import types

import numpy as np

KITCHEN = ("kitchen/reach_a", "kitchen/reach_b", "kitchen/reach_c")
KINOVA = ("kinova/reach_a",)
OBS_DIMS = (9, 6)
MODULE = "icil_paper.sim.kitchen"


class ReachEnv:
    """Move a point by 0.02 m per unit action until it is within 1 cm of the goal."""

    action_dim = 7

    def __init__(self, name: str, obs: str = "state", seed: int = 0, horizon: int = 40,
                 step_delay: float = 0.0):
        self.name = name
        self.obs_kind = obs
        self.horizon = horizon
        self.instruction = f"reach the goal ({name})"
        self.step_delay = step_delay
        self.seed = seed
        self._first = seed
        self.closed = False

    def reset(self, seed=None, options=None):
        seed = self._first if seed is None else seed
        self.seed = int(seed)
        rng = np.random.default_rng(self.seed)
        self.eef = rng.uniform(-0.1, 0.1, 3)
        self.goal = rng.uniform(-0.2, 0.2, 3)
        if self.seed % 10 == 3 and self.seed < 1_000_000:
            self.goal = self.goal + 10.0  # unreachable: the expert fails on this seed
        self.grip = 0.04
        self.steps = 0
        return self._obs(), {"success": False}

    def _obs(self):
        proprio = np.concatenate([self.eef, [0, 0, 0, 1], [self.grip, -self.grip]])
        obs = {"proprio": proprio.astype(np.float32),
               "object": np.concatenate([self.goal, self.goal - self.eef]).astype(np.float32)}
        if self.obs_kind in ("rgb", "rgbd"):
            img = np.zeros((1, 8, 8, 3), np.uint8)
            i, j = (np.clip(self.eef[:2] * 20 + 4, 0, 7)).astype(int)
            img[0, i, j] = 255
            obs["rgb"] = img
            if self.obs_kind == "rgbd":
                obs["depth"] = np.full((1, 8, 8), 1.0 + self.eef[2], np.float32)
        return obs

    def step(self, action):
        if self.step_delay:
            time.sleep(self.step_delay)
        a = np.clip(np.asarray(action, np.float64), -1, 1)
        self.eef = self.eef + 0.02 * a[:3]
        self.grip = 0.0 if a[6] > 0 else 0.04
        self.steps += 1
        success = bool(np.linalg.norm(self.goal - self.eef) < 0.01)
        truncated = self.steps >= self.horizon and not success
        return self._obs(), float(success), success, truncated, {"success": success}

    def get_state(self):
        return np.concatenate([self.eef, self.goal]).astype(np.float32)

    def close(self):
        self.closed = True


class ReachExpert:
    """Proportional controller toward the goal; counts its episodes."""

    episodes = 0

    def reset(self, env, obs):
        ReachExpert.episodes += 1

    def act(self, obs):
        delta = obs["object"][3:6]
        action = np.zeros(7, np.float32)
        action[:3] = np.clip(delta / 0.02, -1, 1)
        action[6] = -1.0
        return action


def make_module(step_delay: float = 0.0) -> types.ModuleType:
    module = types.ModuleType(MODULE)
    module.KITCHEN_TASKS = {name: name for name in KITCHEN}
    module.KINOVA_TASKS = {name: name for name in KINOVA}
    module.KITCHEN_OBS_DIMS = OBS_DIMS
    module.KITCHEN_ZERO_SHOT_SPLIT = {"train": KITCHEN[:2], "held_out": KITCHEN[2:]}
    module.TASK_FAMILIES = {"Reaching": KITCHEN}
    module.make_kitchen_env = lambda name, obs="state", seed=0, **options: ReachEnv(
        name, obs, seed, step_delay=step_delay, **options)
    module.make_kitchen_expert = lambda name: ReachExpert()
    return module


def install(step_delay: float = 0.0) -> None:
    """Put the fake package in place of the kitchen suite (for subprocesses of a test)."""
    import icil_paper.sim as sim

    sys.modules[MODULE] = make_module(step_delay)
    sim._kitchen.cache_clear()
