"""The Meta-World suite's env: one goal-observable Meta-World v3 task as a `TaskEnv`.

Actions: Meta-World moves a Sawyer's hand by a mocap body at 80 Hz; the 7-D action maps as

    a = [dx, dy, dz,  rx, ry, rz,  g]   ->   Meta-World [dx, dy, dz, g]
         x 0.01 m     ignored      +1 closes, -1 opens

Observation: Meta-World's 39-D state, goal included, split into keys:

    proprio (8,)  float32 = hand xyz, gripper opening (0..1) now | the same one step ago
    object  (31,) float32 = obj1 pos, quat | obj2 pos, quat now (14) | one step ago (14) | goal (3)
    rgb     (2, H, W, 3) uint8   cameras corner (turned upright), gripperPOV
    depth   (2, H, W) float32    metres, clipped to the far plane (obs="rgbd")

Layouts come from the episode's seed, drawn from the task's random-reset box. Scene
distributions: `generated`, Meta-World's own box; `human`, layouts from the outer part of
each range and a shifted hand start (`metaworld.tasks`).

The experts are Meta-World's scripted policies (`metaworld.policies`), one per task: a policy
reads the raw 39-D observation and returns [dx, dy, dz, gripper], clipped to [-1, 1] and
placed at [0, 1, 2, 6] of the 7-D action.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from metaworld.env_dict import ALL_V3_ENVIRONMENTS
from metaworld.policies import ENV_POLICY_MAP

from icil_paper.registry import check_name
from icil_paper.sim.base import TaskEnv, observation_space, state_box
from icil_paper.sim.metaworld.tasks import (
    CONTROL_FREQ,
    METAWORLD_TASKS,
    SCENE_DISTRIBUTIONS,
    MetaWorldTaskSpec,
)
from icil_paper.sim.suite import ACTION_DIM

CAMERAS = ("corner", "gripperPOV")
"""Cameras of image observations, in the order of the `rgb` / `depth` arrays."""
_TURNED_CAMERAS = ("corner", "corner2", "corner3", "corner4")
"""Cameras whose XML up axis points down: their images are turned by 180 degrees."""
PROPRIO_LAYOUT = ((3, "metric"), (1, "flag"), (3, "metric"), (1, "flag"))
"""Kinds of the `proprio` entries (the gripper opening is Meta-World's, clipped to [0, 1])."""
_OBJECT_FRAME = ((3, "metric"), (4, "unit"), (3, "metric"), (4, "unit"))
OBJECT_LAYOUT = (*_OBJECT_FRAME, *_OBJECT_FRAME, (3, "metric"))
"""Kinds of the `object` entries: two object poses now, the same one step ago, the goal."""
_PROPRIO_INDEX = np.r_[0:4, 18:22]
_OBJECT_INDEX = np.r_[4:18, 22:36, 36:39]
RAW_DIM = 39


def draw_layout(rng: np.random.Generator, low: np.ndarray, high: np.ndarray,
                outer: float | None = None) -> np.ndarray:
    """One layout vector in [low, high]: uniform, or in the `outer` fraction at either end."""
    u = rng.uniform(size=np.shape(low))
    if outer is not None:  # squeeze [0, 1) onto [0, 2 outer), then lift the upper half
        u = 2 * outer * u
        u = np.where(u < outer, u, u + 1 - 2 * outer)
    return low + u * (high - low)


class _LayoutFromDraws:
    """Mixin before a Meta-World env class: its layout vectors come from `next_layout`
    instead of numpy's global generator; every `reset_model` (Meta-World runs it twice)
    replays the same sequence of draws."""

    next_layout: Callable[[], np.ndarray]
    _layout_draws: list[np.ndarray]
    _layout_cursor: int = 0

    def start_layouts(self, next_layout: Callable[[], np.ndarray]) -> None:
        self.next_layout = next_layout
        self._layout_draws = []

    def reset_model(self):
        self._layout_cursor = 0
        return super().reset_model()

    def _get_state_rand_vec(self) -> np.ndarray:
        if self._layout_cursor == len(self._layout_draws):
            self._layout_draws.append(np.asarray(self.next_layout(), np.float64))
        vec = self._layout_draws[self._layout_cursor]
        self._layout_cursor += 1
        self._last_rand_vec = vec
        return vec


_CLASSES: dict[str, type] = {}


def metaworld_class(metaworld_id: str) -> type:
    """The Meta-World env class of a task (e.g. "drawer-open-v3") with seeded layouts."""
    if metaworld_id not in _CLASSES:
        base = ALL_V3_ENVIRONMENTS[metaworld_id]
        _CLASSES[metaworld_id] = type(f"{base.__name__}Seeded", (_LayoutFromDraws, base), {})
    return _CLASSES[metaworld_id]


def build_metaworld_env(metaworld_id: str):
    """A goal-observable Meta-World env of a task, ready for `start_layouts` and `reset`
    (what `ALL_V3_ENVIRONMENTS_GOAL_OBSERVABLE`'s classes do, on the plain class)."""
    env = metaworld_class(metaworld_id)()
    env._partially_observable = False
    env.__dict__.pop("sawyer_observation_space", None)  # cached with the goal's bounds at 0
    env._set_task_called = True
    env._freeze_rand_vec = True
    env.max_path_length = np.iinfo(np.int64).max  # the wrapper's horizon truncates
    rng, space = np.random.default_rng(0), env._random_reset_space
    env.start_layouts(lambda: draw_layout(rng, space.low, space.high))
    return env


class MetaWorldEnv(TaskEnv):
    """A Meta-World task as a `TaskEnv`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_FREQ}

    def __init__(self, name: str, obs: str = "state", seed: int = 0, camera_size: int = 84,
                 horizon: int | None = None, scenes: str = SCENE_DISTRIBUTIONS[0],
                 render_mode: str | None = None):
        check_name("Meta-World task", name, METAWORLD_TASKS)
        check_name("scene distribution", scenes, SCENE_DISTRIBUTIONS)
        self.task_spec: MetaWorldTaskSpec = METAWORLD_TASKS[name]
        super().__init__(name, obs, seed, horizon=int(horizon or self.task_spec.horizon),
                         instruction=self.task_spec.instruction, render_mode=render_mode)
        self.scenes = scenes
        self.camera_size = int(camera_size)
        self.cameras = CAMERAS if obs != "state" else ()
        self._env = build_metaworld_env(self.task_spec.metaworld_id)
        self.model, self.data = self._env.model, self._env.data
        freq = round(1.0 / self._env.dt)
        if freq != CONTROL_FREQ:
            raise RuntimeError(f"{name}: Meta-World steps at {freq} Hz, the suite expects "
                               f"{CONTROL_FREQ} Hz (metaworld's version differs from 3.1.1?)")
        self._hand_init = np.array(self._env.hand_init_pos, np.float64)
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._raw = np.zeros(RAW_DIM)
        self.far = float(self.model.vis.map.zfar * self.model.stat.extent)
        self.observation_space = observation_space(
            state_box(PROPRIO_LAYOUT), state_box(OBJECT_LAYOUT), obs,
            image=(len(self.cameras), self.camera_size, self.camera_size),
            depth_range=(0.0, self.far))

    # gymnasium interface ----------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        self._begin_episode(seed)
        rng = np.random.default_rng(self.seed)
        hand, outer = self._hand_init.copy(), None
        if self.scenes == "human":
            shift, outer = self.task_spec.hand_shift, self.task_spec.outer
            hand += rng.uniform(-shift, shift, 3)
        self._env.hand_init_pos = hand
        space = self._env._random_reset_space
        self._env.start_layouts(lambda: draw_layout(rng, space.low, space.high, outer))
        raw, _ = self._env.reset()
        self._raw = np.asarray(raw, np.float64)
        return self._obs(), {"success": False}

    def step(self, action):
        a = self._checked_action(action)
        raw, reward, _, _, mw_info = self._env.step(a[[0, 1, 2, 6]])
        self._raw = np.asarray(raw, np.float64)
        success = bool(mw_info["success"])
        terminated, truncated = self._step_outcome(success)
        info = {"success": success, "near_object": bool(mw_info.get("near_object", 0.0)),
                "grasp_success": bool(mw_info.get("grasp_success", 0.0))}
        return self._obs(), float(reward), terminated, truncated, info

    def render(self, camera: str = "corner", size: int | tuple[int, int] = 256) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 from a camera of the scene (`model`'s cameras)."""
        width, height = (size, size) if np.isscalar(size) else size
        return self._render(camera, int(height), int(width))

    def raw_observation(self) -> np.ndarray:
        """Meta-World's last 39-D observation (float64; module docstring), for its experts."""
        return self._raw.copy()

    @property
    def layout(self) -> np.ndarray:
        """The episode's layout vector (Meta-World's `_last_rand_vec`)."""
        return np.array(self._env._last_rand_vec, np.float64)

    @property
    def metaworld_env(self):
        """The Meta-World env inside (a `SawyerXYZEnv`)."""
        return self._env

    def get_state(self) -> np.ndarray:
        """Flat MuJoCo state (time, qpos, qvel, mocap position and quaternion) as float64."""
        d = self.data
        return np.concatenate([[d.time], d.qpos, d.qvel, d.mocap_pos.ravel(),
                               d.mocap_quat.ravel()]).astype(np.float64)

    def eef_position(self) -> np.ndarray:
        """The hand's world position (3,) float64, metres (`proprio[:3]`)."""
        return np.array(self._env.get_endeff_pos(), np.float64)

    def _close(self) -> None:
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
        self._env.close()

    # -----------------------------------------------------------------------------------------
    def _renderer(self, height: int, width: int) -> mujoco.Renderer:
        if (height, width) not in self._renderers:
            vis = self.model.vis
            vis.global_.offwidth = max(vis.global_.offwidth, width)
            vis.global_.offheight = max(vis.global_.offheight, height)
            vis.quality.offsamples = 0  # no multisampling: faster on software renderers
            renderer = mujoco.Renderer(self.model, height, width)
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                         mujoco.mjtRndFlag.mjRND_SKYBOX):
                renderer.scene.flags[flag] = False  # 5-7x faster, images barely change
            self._renderers[height, width] = renderer
        return self._renderers[height, width]

    def _render(self, camera: str, height: int, width: int, depth: bool = False) -> np.ndarray:
        renderer = self._renderer(height, width)
        if depth:
            renderer.enable_depth_rendering()
        try:
            renderer.update_scene(self.data, camera=camera)
            image = renderer.render()
        finally:
            if depth:
                renderer.disable_depth_rendering()
        if camera in _TURNED_CAMERAS:
            image = image[::-1, ::-1]
        return np.ascontiguousarray(image)

    def _obs(self) -> dict[str, np.ndarray]:
        out = {"proprio": self._raw[_PROPRIO_INDEX].astype(np.float32),
               "object": self._raw[_OBJECT_INDEX].astype(np.float32)}
        if self.obs_kind != "state":
            size = self.camera_size
            out["rgb"] = np.stack([self._render(c, size, size) for c in self.cameras])
            if self.obs_kind == "rgbd":
                depth = np.stack([self._render(c, size, size, depth=True) for c in self.cameras])
                out["depth"] = np.minimum(depth, self.far).astype(np.float32)
        return out

    def __repr__(self) -> str:
        return f"MetaWorldEnv({self.name!r}, obs={self.obs_kind!r}, scenes={self.scenes!r})"


POLICY_CLASSES: dict[str, type] = {
    task: ENV_POLICY_MAP[spec.metaworld_id] for task, spec in METAWORLD_TASKS.items()}
"""Task name -> its scripted policy class (Meta-World's own map)."""


class MetaWorldExpert:
    """A task's scripted Meta-World policy as the suite's expert; `noise_std` adds Gaussian
    noise (action units, before clipping), seeded with the env's episode seed."""

    def __init__(self, task: str, noise_std: float = 0.0):
        check_name("Meta-World task", task, METAWORLD_TASKS)
        self.task = task
        self.policy = POLICY_CLASSES[task]()
        self.noise_std = float(noise_std)
        self.env: Any = None
        self.rng = np.random.default_rng(0)

    def reset(self, env: Any, obs: dict[str, np.ndarray] | None = None) -> None:
        """Start an episode of `env` (a reset `MetaWorldEnv`)."""
        if not hasattr(env, "raw_observation"):
            raise TypeError(f"{self.task}: the expert needs a MetaWorldEnv (with "
                            f"raw_observation()), got {type(env).__name__}")
        self.env = env
        self.rng = np.random.default_rng([int(env.seed or 0), 0x4D57])  # "MW"

    def act(self, obs: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The action (7,) float32 in [-1, 1] for the env's current state."""
        if self.env is None:
            raise RuntimeError(f"{self.task}: call expert.reset(env, obs) before act")
        move = np.asarray(self.policy.get_action(self.env.raw_observation()), np.float64)
        if self.noise_std > 0:
            move = move + self.rng.normal(0.0, self.noise_std, move.shape)
        action = np.zeros(ACTION_DIM, np.float32)
        action[[0, 1, 2, 6]] = np.clip(move, -1.0, 1.0)
        return action
