"""A simulator-free stand-in for the kitchen and Kinova suites, for the registry and data tests.

A point "end effector" reaches a goal; it is a `TaskEnv` like the real suites (obs dict with
proprio (9,) and object (6,), 7-D actions, `info["success"]`), so the registry, the sources and
the data tooling can be tested in milliseconds. Seeds ending in 3 put the goal out of
reach (first attempts only: seeds below 1e6 ending in 3), so the expert fails there and
generation must move on to the demo's next seed.

`use(monkeypatch)` / `install()` point the suite registry's kitchen and Kinova entries at the
records below (`BROKEN` at a record that does not exist).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from icil_paper.sim.base import TaskEnv, observation_space, state_box
from icil_paper.sim.suite import Suite

KITCHEN = ("kitchen/reach_a", "kitchen/reach_b", "kitchen/reach_c")
KINOVA = ("kinova/reach_a",)
OBS_DIMS = (9, 6)
STEP_DELAY = {"seconds": 0.0}
"""Seconds each step sleeps (a slow env for the kill-and-resume test)."""


class ReachEnv(TaskEnv):
    """Move a point by 0.02 m per unit action until it is within 1 cm of the goal."""

    def __init__(self, name: str, obs: str = "state", seed: int = 0, horizon: int = 40,
                 render_mode: str | None = None):
        super().__init__(name, obs, seed, horizon=horizon,
                         instruction=f"reach the goal ({name})", render_mode=render_mode)
        self.cameras = ("cam",) if obs != "state" else ()
        self.observation_space = observation_space(
            state_box(((3, "metric"), (4, "unit"), (2, "metric"))),
            state_box(((6, "metric"),)), obs, image=(1, 8, 8), depth_range=(0.0, 2.0))
        self.closed = False

    def reset(self, seed=None, options=None):
        self._begin_episode(seed)
        rng = np.random.default_rng(self.seed)
        self.eef = rng.uniform(-0.1, 0.1, 3)
        self.goal = rng.uniform(-0.2, 0.2, 3)
        if self.seed % 10 == 3 and self.seed < 1_000_000:
            self.goal = self.goal + 5.0  # unreachable: the expert fails on this seed
        self.grip = 0.04
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
        if STEP_DELAY["seconds"]:
            time.sleep(STEP_DELAY["seconds"])
        a = np.clip(np.asarray(action, np.float64), -1, 1)
        self.eef = self.eef + 0.02 * a[:3]
        self.grip = 0.0 if a[6] > 0 else 0.04
        success = bool(np.linalg.norm(self.goal - self.eef) < 0.01)
        terminated, truncated = self._step_outcome(success)
        return self._obs(), float(success), terminated, truncated, {"success": success}

    def render(self):
        return np.zeros((8, 8, 3), np.uint8)

    def get_state(self):
        return np.concatenate([self.eef, self.goal]).astype(np.float64)

    def eef_position(self):
        return self.eef.astype(np.float64)

    def _close(self):
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


def make_env(name, obs="state", seed=0, **options):
    return ReachEnv(name, obs, seed, **options)


def make_expert(name):
    return ReachExpert()


KITCHEN_SUITE = Suite(name="kitchen", tasks=KITCHEN, obs_dims=OBS_DIMS, control_freq=20,
                      make_env=make_env, make_expert=make_expert, object_position=(0, 3))
KINOVA_SUITE = Suite(name="kinova", tasks=KINOVA, obs_dims=OBS_DIMS, control_freq=20,
                     make_env=make_env, make_expert=make_expert, object_position=(0, 3))


def registry(broken: bool = False) -> dict:
    """The suite registry with the kitchen and Kinova entries pointing here."""
    import icil_paper.sim as sim

    def load(record: str):  # as importing a module that lacks the record, when broken
        return lambda: getattr(sys.modules[__name__], "NO_SUCH_RECORD" if broken else record)

    return {**sim.SUITE_REGISTRY, "kitchen": load("KITCHEN_SUITE"), "kinova": load("KINOVA_SUITE")}


def use(monkeypatch, broken: bool = False) -> None:
    """Put the fake suites in place for one test."""
    import icil_paper.sim as sim

    monkeypatch.setattr(sim, "SUITE_REGISTRY", registry(broken))


def install(step_delay: float = 0.0) -> None:
    """Put the fake suites in place for a whole process (subprocesses of a test)."""
    import icil_paper.sim as sim

    STEP_DELAY["seconds"] = step_delay
    sim.SUITE_REGISTRY = registry()
