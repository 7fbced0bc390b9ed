"""The synthetic suite: a tiny simulator-free reach task family for tests and benchmarks.

Task k (`synthetic/task<k>`) is "move the end effector to goal g_k", where g_k is *not* part
of the observation: only a prompt demonstration reveals it. The position moves by STEP_SIZE
x the first three action dimensions each step.

    demos = synthetic_demos(n_tasks=2, per_task=3, steps=20)     # Demo-like objects
    env = make_env("synthetic/task0")                            # icil_paper.sim.make_env
    obs, info = env.reset(seed=1); obs, r, term, trunc, info = env.step(action)

Observation: proprio (9,) = position (3) | a state that follows it (6, in [-1, 1]); object (6,)
= noise fixed at reset; "rgb" (n_cams, H, W, 3) draws a blob where the position is.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from icil_paper.sim.base import TaskEnv, observation_space, state_box
from icil_paper.sim.suite import Suite

STEP_SIZE = 0.08
SUCCESS_RADIUS = 0.1
N_TASKS = 10
"""Tasks of the registered suite (`synthetic_demos` makes any number)."""
CONTROL_FREQ = 20
"""Nominal control rate, Hz (the dynamics have no time scale; the other suites' rate)."""


def task_goal(task: str) -> np.ndarray:
    """The hidden goal (3,) of `synthetic/task<k>`."""
    k = int(task.rsplit("task", 1)[-1])
    return np.random.default_rng(1000 + k).uniform(-0.8, 0.8, size=3)


def expert_action(p: np.ndarray, goal: np.ndarray, action_dim: int) -> np.ndarray:
    """A smooth, saturated step towards the goal; the gripper closes near it."""
    a = np.zeros(action_dim)
    delta = goal - p[:3]
    a[:3] = np.clip(delta * 4.0, -1, 1)
    if action_dim > 3:
        a[-1] = 1.0 if np.linalg.norm(delta) < 0.15 else -1.0
    return a


def _step_state(p: np.ndarray, a: np.ndarray) -> np.ndarray:
    p = p.copy()
    p[:3] = p[:3] + STEP_SIZE * a[:3]
    p[3:] = 0.9 * p[3:] + 0.1 * np.tanh(p[:3].sum())
    return p


def _initial_state(rng: np.random.Generator, proprio_dim: int, object_dim: int):
    p = np.zeros(proprio_dim)
    p[:3] = rng.uniform(-0.3, 0.3, size=3)
    return p, rng.normal(0, 0.1, size=object_dim)


@dataclass
class SyntheticDemo:
    """A demonstration with the fields of `icil_paper.data.Demo`."""

    actions: np.ndarray
    obs: dict[str, np.ndarray]
    task: str = "synthetic/task0"
    source: str = "synthetic"
    instruction: str = "reach goal number 0"
    seed: int = 0
    attrs: dict[str, Any] = field(default_factory=dict)


def synthetic_demos(n_tasks: int = 2, per_task: int = 3, steps: int | tuple[int, int] = 20,
                    proprio_dim: int = 9, object_dim: int = 6, action_dim: int = 7,
                    image: tuple[int, int, int] | None = None, depth: bool = False,
                    seed: int = 0) -> list[SyntheticDemo]:
    """Expert demonstrations of tasks 0 .. n_tasks - 1 (`per_task` each); `steps` is the
    length or a (low, high) range; `image` = (n_cams, H, W) adds "rgb" (and `depth` "depth")."""
    demos = []
    for k in range(n_tasks):
        task = f"synthetic/task{k}"
        goal = task_goal(task)
        for i in range(per_task):
            demo_seed = seed * 1000 + k * 100 + i
            rng = np.random.default_rng(demo_seed)
            T = steps if isinstance(steps, int) else int(rng.integers(steps[0], steps[1] + 1))
            p, obj = _initial_state(rng, proprio_dim, object_dim)
            P, O, A = [], [], []
            for _ in range(T):
                a = expert_action(p, goal, action_dim)
                P.append(p.copy())
                O.append(obj.copy())
                A.append(a)
                p = _step_state(p, a)
            obs = {"proprio": np.asarray(P, np.float32), "object": np.asarray(O, np.float32)}
            if image is not None:
                obs["rgb"] = blob_images(obs["proprio"][:, :2], image)
                if depth:
                    obs["depth"] = obs["rgb"][..., 0].astype(np.float32) / 255.0
            demos.append(SyntheticDemo(np.asarray(A, np.float32), obs, task=task,
                                       instruction=f"reach goal number {k}", seed=demo_seed))
    return demos


def blob_images(xy: np.ndarray, image: tuple[int, int, int]) -> np.ndarray:
    """(T, 2) positions in [-1, 1] -> (T, n_cams, H, W, 3) uint8 images of a blob there."""
    n, H, W = image
    yy, xx = np.mgrid[0:H, 0:W]
    cy = (xy[:, 1] * 0.5 + 0.5) * (H - 1)
    cx = (xy[:, 0] * 0.5 + 0.5) * (W - 1)
    d2 = (yy[None] - cy[:, None, None]) ** 2 + (xx[None] - cx[:, None, None]) ** 2
    blob = (255 * np.exp(-d2 / (0.02 * H * W))).astype(np.uint8)  # (T, H, W)
    img = np.zeros((len(xy), n, H, W, 3), np.uint8)
    img[..., 0] = blob[:, None]
    img[..., 1] = 255 - blob[:, None]
    return img


class SyntheticReachEnv(TaskEnv):
    """The environment of `synthetic_demos` as a `gymnasium.Env` (`icil_paper.sim.base`)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_FREQ}

    def __init__(self, name: str = "synthetic/task0", obs: str = "state", seed: int = 0,
                 horizon: int = 40, proprio_dim: int = 9, object_dim: int = 6,
                 image: tuple[int, int, int] = (1, 16, 16), render_mode: str | None = None):
        super().__init__(name, obs, seed, horizon=horizon,
                         instruction=f"reach goal number {name.rsplit('task', 1)[-1]}",
                         render_mode=render_mode)
        self.goal = task_goal(name)
        self.dims, self.image = (proprio_dim, object_dim), tuple(image)
        self.cameras = tuple(f"camera{i}" for i in range(self.image[0])) if obs != "state" else ()
        self.observation_space = observation_space(
            state_box(((3, "free"), (proprio_dim - 3, "unit"))),
            state_box(((object_dim, "free"),)), obs, image=self.image, depth_range=(0.0, 1.0))
        self.p, self.obj = _initial_state(np.random.default_rng(seed), *self.dims)

    def _obs(self) -> dict[str, np.ndarray]:
        obs = {"proprio": self.p.astype(np.float32), "object": self.obj.astype(np.float32)}
        if self.obs_kind in ("rgb", "rgbd"):
            obs["rgb"] = blob_images(self.p[None, :2], self.image)[0]
            if self.obs_kind == "rgbd":
                obs["depth"] = obs["rgb"][..., 0].astype(np.float32) / 255.0
        return obs

    def reset(self, seed: int | None = None, options: dict | None = None):
        self._begin_episode(seed)
        self.p, self.obj = _initial_state(self.np_random, *self.dims)
        return self._obs(), {"success": False}

    def step(self, action):
        self.p = _step_state(self.p, self._checked_action(action))
        success = bool(np.linalg.norm(self.p[:3] - self.goal) < SUCCESS_RADIUS)
        terminated, truncated = self._step_outcome(success)
        return self._obs(), float(success), terminated, truncated, {"success": success}

    def render(self, size: int = 64) -> np.ndarray:
        """An RGB frame (size, size, 3) uint8 with the blob where the end effector is."""
        return blob_images(self.p[None, :2], (1, size, size))[0, 0]

    def get_state(self) -> np.ndarray:
        """The position state and the object noise, float64."""
        return np.concatenate([self.p, self.obj]).astype(np.float64)

    def eef_position(self) -> np.ndarray:
        """The point's position (3,) float64 (`proprio[:3]`)."""
        return self.p[:3].astype(np.float64)


class SyntheticExpert:
    """Steers to the task's goal, read from the env (as scripted experts read the simulator)."""

    def reset(self, env: Any, obs: dict[str, np.ndarray]) -> None:
        self.goal = getattr(env, "unwrapped", env).goal

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return expert_action(np.asarray(obs["proprio"], np.float64), self.goal,
                             7).astype(np.float32)


make_synthetic_env = SyntheticReachEnv
"""`make_env`-compatible factory for `synthetic/task<k>` (usable by `evaluate_policy`)."""


def make_synthetic_expert(name: str) -> SyntheticExpert:
    """The expert of a synthetic task."""
    return SyntheticExpert()


SYNTHETIC_SUITE = Suite(
    name="synthetic", tasks=tuple(f"synthetic/task{k}" for k in range(N_TASKS)),
    obs_dims=(9, 6), control_freq=CONTROL_FREQ, make_env=make_synthetic_env,
    make_expert=make_synthetic_expert, object_position=None,
    description="simulator-free reach tasks whose goal only a prompt demonstration reveals")
