"""`TaskEnv`: the `gymnasium.Env` that every suite's environment extends.

What every task env has, whatever the simulator::

    env.name, env.instruction, env.horizon    task name, language instruction, step limit
    env.obs_kind                              "state", "rgb" or "rgbd"
    env.action_dim = 7                        [dx, dy, dz, rx, ry, rz, gripper] in [-1, 1]
    env.cameras                               camera names of obs["rgb"] (empty for "state")
    env.seed, env.control_dt                  seed of the current episode; seconds per step
    env.action_space, env.observation_space   Box(-1, 1, (7,)); Dict(proprio, object[, rgb, depth])
    env.eef_position()                        (3,) end-effector position in metres (no noise)

    obs, info = env.reset(seed=None)           info["success"]: the task's predicate, a bool
    obs, reward, terminated, truncated, info = env.step(action)
    frame = env.render()                       (H, W, 3) uint8

An episode is fully determined by its seed; `reset()` runs the constructor's seed first,
then seeds drawn from a generator seeded by the last explicit seed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from icil_paper.registry import check_name
from icil_paper.sim.suite import ACTION_DIM, OBS_KINDS

METRIC_BOUND = 10.0
"""Bound (m or rad) of every position, distance and joint entry of the state observations."""
NOISE_MARGIN = 8.0
"""Standard deviations of observation noise added to the bounds of noisy observations."""
_KIND_BOUNDS = {"metric": (-METRIC_BOUND, METRIC_BOUND), "unit": (-1.0, 1.0), "flag": (0.0, 1.0),
                "free": (-np.inf, np.inf)}


def state_box(layout: Sequence[tuple[int, str]], noise_std: float = 0.0) -> spaces.Box:
    """A float32 Box from (width, kind) segments, kind "metric", "unit", "flag" or "free"."""
    low = np.concatenate([np.full(n, _KIND_BOUNDS[kind][0]) for n, kind in layout])
    high = np.concatenate([np.full(n, _KIND_BOUNDS[kind][1]) for n, kind in layout])
    margin = NOISE_MARGIN * float(noise_std)
    return spaces.Box((low - margin).astype(np.float32), (high + margin).astype(np.float32),
                      dtype=np.float32)


def observation_space(proprio: spaces.Box, obj: spaces.Box, obs_kind: str,
                      image: tuple[int, int, int] | None = None,
                      depth_range: tuple[float, float] = (0.0, np.inf)) -> spaces.Dict:
    """The Dict space of an observation kind: proprio and object, plus rgb (n_cams, H, W, 3)
    uint8 and depth (n_cams, H, W) float32 in `depth_range` (metres) when the kind has them."""
    entries: dict[str, spaces.Space] = {"proprio": proprio, "object": obj}
    if obs_kind in ("rgb", "rgbd"):
        if image is None:
            raise ValueError(f"observation kind {obs_kind!r} needs the image shape")
        entries["rgb"] = spaces.Box(0, 255, (*image, 3), dtype=np.uint8)
        if obs_kind == "rgbd":
            entries["depth"] = spaces.Box(np.float32(depth_range[0]), np.float32(depth_range[1]),
                                          image, dtype=np.float32)
    return spaces.Dict(entries)


class TaskEnv(gym.Env):
    """Base class of the task envs: a subclass sets `observation_space`, and implements
    `reset` (starting with `self._begin_episode(seed)`), `step`, `render`, `eef_position`
    and `_close`."""

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 20}
    action_dim = ACTION_DIM
    cameras: tuple[str, ...] = ()

    def __init__(self, name: str, obs: str = "state", seed: int = 0, *, horizon: int,
                 instruction: str, render_mode: str | None = None):
        check_name("observation kind", obs, OBS_KINDS)
        if render_mode is not None:
            check_name("render mode", render_mode, self.metadata["render_modes"])
        self.name = name
        self.obs_kind = obs
        self.horizon = int(horizon)
        self.instruction = instruction
        self.render_mode = render_mode
        self.action_space = spaces.Box(-1.0, 1.0, (ACTION_DIM,), dtype=np.float32)
        self._seed_stream = np.random.default_rng(int(seed))
        self._first_seed: int | None = int(seed)
        self.seed: int | None = None
        self.steps = 0
        self._closed = False

    def _begin_episode(self, seed: int | None) -> int:
        """Choose the episode's seed, seed `np_random` with it, return it."""
        if seed is None:
            seed = (self._first_seed if self._first_seed is not None
                    else int(self._seed_stream.integers(2**31 - 1)))
        else:
            self._seed_stream = np.random.default_rng(int(seed))
        self._first_seed = None
        self.seed = int(seed)
        super().reset(seed=self.seed)
        self.steps = 0
        return self.seed

    def _checked_action(self, action) -> np.ndarray:
        """`action` as a (ACTION_DIM,) float64 array clipped to [-1, 1]; ValueError if malformed."""
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), -1.0, 1.0)
        if a.shape != (ACTION_DIM,):
            raise ValueError(f"{self.name}: action must have {ACTION_DIM} entries, got "
                             f"{a.shape[0]}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{self.name}: action has non-finite entries: {a}")
        return a

    def _step_outcome(self, success: bool) -> tuple[bool, bool]:
        """(terminated, truncated) after a step: success ends the episode, the horizon cuts it."""
        self.steps += 1
        terminated = bool(success)
        return terminated, bool(self.steps >= self.horizon and not terminated)

    def get_state(self) -> np.ndarray:
        """Flat simulator state (float64), robomimic's `states` entry."""
        raise NotImplementedError

    def eef_position(self) -> np.ndarray:
        """The end effector's position now, (3,) float64 metres (world frame, no noise)."""
        raise NotImplementedError

    @property
    def control_dt(self) -> float:
        """Seconds of simulated time per env step: 1 / the control rate (`render_fps`)."""
        return 1.0 / float(self.metadata["render_fps"])

    def close(self) -> None:
        """Release the simulator; closing twice is allowed."""
        if not self._closed:
            self._closed = True
            self._close()

    def _close(self) -> None:
        pass

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, obs={self.obs_kind!r})"
