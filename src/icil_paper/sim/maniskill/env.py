"""The ManiSkill suite's env: PickCube-v1, PushCube-v1 and StackCube-v1 as the project's envs.

Action (7-D in [-1, 1], as the kitchen suite's), ManiSkill's `pd_ee_delta_pose` controller::

    a = [dx, dy, dz,  rx, ry, rz,  g]
         x 0.1 m      x 0.1 rad    +1 closes, -1 opens (robosuite's sign)

Observations (the same keys for every task of the suite)::

    proprio (9,)  = tcp position (3) | tcp quaternion x, y, z, w (4) | finger offsets (2)
    object  (21,) = object pose (7) | tcp -> object (3) | object grasped (1) | target pose (7)
                    | object -> target (3)
    rgb     (1, H, W, 3) uint8   and depth (1, H, W) float32 metres, for obs="rgb"/"rgbd"

`proprio` has robosuite's layout. The target is PickCube's goal point, PushCube's goal
region, or the spot one cube height above StackCube's cube B.

ManiSkill 3 needs a Vulkan device even for state observations (without a GPU: Mesa's
lavapipe, 24.3 or newer); building an env raises `RenderingUnavailable` naming the fix
instead of SAPIEN's bare error.
"""

from __future__ import annotations

import functools
import gc
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from icil_paper.setup.envcheck import MANUAL_FIX
from icil_paper.setup.envcheck import vulkan_problem as probe
from icil_paper.sim.base import TaskEnv, observation_space, state_box
from icil_paper.sim.suite import ACTION_DIM

PROPRIO_DIM = 9
MANISKILL_OBJECT_DIM = 21
MANISKILL_OBS_DIMS = (PROPRIO_DIM, MANISKILL_OBJECT_DIM)
CONTROL_FREQ = 20
"""Control rate of the suite's tasks, Hz (ManiSkill's default for PickCube, PushCube, StackCube)."""
PROPRIO_LAYOUT = ((3, "metric"), (4, "unit"), (2, "metric"))
"""Kinds of the `proprio` entries, for the observation space (`icil_paper.sim.base.state_box`)."""
OBJECT_LAYOUT = ((3, "metric"), (4, "unit"), (3, "metric"), (1, "flag"), (3, "metric"),
                 (4, "unit"), (3, "metric"))
"""Kinds of the `object` entries (module docstring)."""
DEPTH_FAR = 100.0
"""Metres: the far plane of ManiSkill's cameras, the bound of depth observations."""
POS_SCALE = 0.1
"""Metres of end-effector translation per unit of action (ManiSkill's pd_ee_delta_pose bound)."""
ROT_SCALE = 0.1
"""Radians of end-effector rotation per unit of action (ManiSkill's pd_ee_delta_pose bound)."""
_IDENTITY_QUAT_XYZW = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float32)


LAVAPIPE_HOWTO = (
    "ManiSkill (SAPIEN 3) needs a Vulkan device, even for state observations. With an NVIDIA "
    "GPU install the driver's Vulkan ICD (libnvidia-gl). Without a GPU install Mesa's software "
    "driver lavapipe, version 24.3 or newer (SAPIEN needs VK_KHR_external_semaphore_fd): on "
    "Debian 12 as root, `make setup` does it (python -m tools.system_deps --install), or by "
    "hand: add the 'bookworm-backports' suite of your Debian mirror to apt, then `apt-get update "
    "&& apt-get install -t bookworm-backports mesa-vulkan-drivers`; on Ubuntu 24.10 or newer "
    "`apt-get install mesa-vulkan-drivers`. Check with `vulkaninfo --summary` (package "
    "vulkan-tools) that a device named 'llvmpipe' is listed."
)


class RenderingUnavailable(RuntimeError):
    """The simulator cannot start because the machine lacks a rendering device."""


@functools.lru_cache(maxsize=1)
def vulkan_problem() -> str | None:
    """None when SAPIEN finds a Vulkan device, else the problem and the fix (probed once)."""
    problem = probe()
    if problem is None:
        return None
    return f"{problem.replace(MANUAL_FIX, '').strip()} {LAVAPIPE_HOWTO}"


def vulkan_available() -> bool:
    """Whether ManiSkill can start on this machine."""
    return vulkan_problem() is None


def vulkan_skip_reason() -> str:
    """The reason ManiSkill tests give when they skip ('' when Vulkan works)."""
    problem = vulkan_problem()
    return "" if problem is None else f"ManiSkill cannot start: {problem}"


@dataclass(frozen=True)
class ManiSkillTask:
    """One ManiSkill task of the suite."""

    name: str
    """Registry name, `maniskill/<task>`."""
    env_id: str
    """ManiSkill's gymnasium id."""
    horizon: int
    """Step limit of an episode (room for the `human` source's slower demos)."""
    instruction: str
    """Language instruction of the task."""
    solver: str
    """Name of the motion-planning solution in `mani_skill.examples.motionplanning.panda.solutions`."""


MANISKILL_TASKS: dict[str, ManiSkillTask] = {
    t.name: t for t in (
        ManiSkillTask("maniskill/pick_cube", "PickCube-v1", 150,
                      "pick up the red cube and move it to the green goal", "solvePickCube"),
        ManiSkillTask("maniskill/push_cube", "PushCube-v1", 150,
                      "push the cube into the target region", "solvePushCube"),
        ManiSkillTask("maniskill/stack_cube", "StackCube-v1", 200,
                      "stack the red cube on top of the green cube", "solveStackCube"),
    )
}


def to_numpy(x: Any) -> np.ndarray:
    """First element of a batched ManiSkill tensor as a float32 numpy array."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    x = np.asarray(x)
    return x[0] if x.ndim >= 1 and x.shape[0] == 1 else x


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def default_sim_backend() -> str:
    """`physx_cuda` when torch sees a CUDA GPU, else `physx_cpu`."""
    try:
        import torch

        return "physx_cuda" if torch.cuda.is_available() else "physx_cpu"
    except ImportError:
        return "physx_cpu"


def default_render_backend() -> str:
    """ManiSkill's render backend: `gpu` with a CUDA GPU, else `cpu` (Vulkan via lavapipe)."""
    return "gpu" if default_sim_backend() == "physx_cuda" else "cpu"


def _pose7(p: np.ndarray, q_wxyz: np.ndarray) -> np.ndarray:
    return np.concatenate([p, wxyz_to_xyzw(q_wxyz)]).astype(np.float32)


def object_features(task: str, base_env: Any) -> np.ndarray:
    """The suite's object-state vector (MANISKILL_OBJECT_DIM,) read from a ManiSkill env."""
    agent = base_env.agent
    tcp = to_numpy(agent.tcp.pose.p)
    if task == "maniskill/stack_cube":
        obj = base_env.cubeA
        half = float(to_numpy(base_env.cube_half_size)[2])
        b_pose = base_env.cubeB.pose
        target = _pose7(to_numpy(b_pose.p) + np.array([0.0, 0.0, 2 * half], np.float32), to_numpy(b_pose.q))
    else:
        obj = base_env.cube if task == "maniskill/pick_cube" else base_env.obj
        goal = base_env.goal_site if task == "maniskill/pick_cube" else base_env.goal_region
        target = np.concatenate([to_numpy(goal.pose.p), _IDENTITY_QUAT_XYZW]).astype(np.float32)
    obj_p, obj_q = to_numpy(obj.pose.p), to_numpy(obj.pose.q)
    grasped = np.array([float(to_numpy(agent.is_grasping(obj)))], np.float32)
    return np.concatenate([_pose7(obj_p, obj_q), obj_p - tcp, grasped, target,
                           target[:3] - obj_p]).astype(np.float32)  # (MANISKILL_OBJECT_DIM,)


def proprio_features(base_env: Any) -> np.ndarray:
    """tcp position (3) | tcp quaternion xyzw, canonical sign (4) | finger offsets (2)."""
    pose = base_env.agent.tcp.pose
    quat = wxyz_to_xyzw(to_numpy(pose.q))
    if quat[0] < 0:  # q and -q are one rotation: keep the sign facing the reset orientation
        quat = -quat
    fingers = to_numpy(base_env.agent.robot.get_qpos())[-2:]
    return np.concatenate([to_numpy(pose.p), quat, [fingers[0], -fingers[1]]]).astype(np.float32)


def policy_to_maniskill_action(action: np.ndarray) -> np.ndarray:
    """Map the suite's 7-D action onto ManiSkill's normalized pd_ee_delta_pose action: the
    axis-angle rotation becomes XYZ Euler angles over `rot_lower` (-0.1), the gripper flips."""
    from scipy.spatial.transform import Rotation  # here: listing the suite stays cheap

    a = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), -1.0, 1.0)
    if a.shape != (ACTION_DIM,):
        raise ValueError(f"action must have {ACTION_DIM} entries, got shape {np.shape(action)}")
    rot = a[3:6]
    norm = np.linalg.norm(rot)
    if norm > 1.0:
        rot = rot / norm
    euler = Rotation.from_rotvec(rot * ROT_SCALE).as_euler("XYZ")
    out = np.empty(ACTION_DIM, np.float32)
    out[:3] = a[:3]
    out[3:6] = euler / -ROT_SCALE
    out[6] = -a[6]
    return out


class ManiSkillEnv(TaskEnv):
    """A ManiSkill task as a `TaskEnv`.

    Every reset rebuilds the scene (`reconfigure`), since PhysX keeps solver state across a
    plain reset; `deterministic_reset=False` skips the rebuild.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_FREQ}

    def __init__(self, task: str, obs: str = "state", seed: int = 0,
                 sim_backend: str | None = None, camera_size: int | None = None,
                 horizon: int | None = None, render_size: int | None = None,
                 deterministic_reset: bool = True, render_mode: str | None = None):
        import gymnasium as gym
        import mani_skill.envs  # noqa: F401  (registers the environments)

        # ManiSkill's scene rebuild runs a full gc.collect() (0.3 s with torch loaded):
        # freeze what exists now so a reset scans only what was made since.
        gc.collect()
        gc.freeze()
        self.task_spec = MANISKILL_TASKS[task]
        super().__init__(task, obs, seed, horizon=int(horizon or self.task_spec.horizon),
                         instruction=self.task_spec.instruction, render_mode=render_mode)
        self.sim_backend = sim_backend or default_sim_backend()
        kwargs: dict[str, Any] = {}
        if camera_size is not None:
            kwargs["sensor_configs"] = {"width": camera_size, "height": camera_size}
        if render_size is not None:
            kwargs["human_render_camera_configs"] = {"width": render_size, "height": render_size}
        obs_mode = {"state": "none", "rgb": "rgb", "rgbd": "rgbd"}[obs]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self._env = gym.make(self.task_spec.env_id, obs_mode=obs_mode,
                                     control_mode="pd_ee_delta_pose",
                                     sim_backend=self.sim_backend,
                                     render_backend=default_render_backend(),
                                     render_mode="rgb_array", max_episode_steps=10**6, **kwargs)
        except RuntimeError as exc:  # SAPIEN's bare Vulkan errors, explained
            if any(k in str(exc) for k in ("rendering device", "vk::", "Vulkan", "vulkan")):
                raise RenderingUnavailable(f"ManiSkill cannot start: {exc}. {LAVAPIPE_HOWTO}"
                                           ) from exc
            raise
        self.base = self._env.unwrapped
        root_q = to_numpy(self.base.agent.robot.pose.q)
        if not np.allclose(np.abs(root_q[0]), 1.0, atol=1e-6):
            raise RuntimeError(f"{task}: the robot base is rotated ({root_q}); the action frame "
                               "assumes a base aligned with the world axes")
        self.deterministic_reset = deterministic_reset
        sensors = dict(self.base._sensors) if obs != "state" else {}
        self.cameras = tuple(sensors)
        size = (next(iter(sensors.values())).config.height,
                next(iter(sensors.values())).config.width) if sensors else (0, 0)
        self.observation_space = observation_space(
            state_box(PROPRIO_LAYOUT), state_box(OBJECT_LAYOUT), obs,
            image=(len(self.cameras), *size), depth_range=(0.0, DEPTH_FAR))

    # gymnasium interface ----------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        self._begin_episode(seed)
        if self.deterministic_reset:
            options = {"reconfigure": True, **(options or {})}
        raw, _ = self._env.reset(seed=self.seed, options=options)
        self.base = self._env.unwrapped
        return self._make_obs(raw), self._info(self.base.evaluate())

    def step(self, action):
        raw, reward, _, _, info = self._env.step(policy_to_maniskill_action(action))
        obs = self._make_obs(raw)
        info = self._info(info)
        terminated, truncated = self._step_outcome(info["success"])
        return obs, float(to_numpy(reward)), terminated, truncated, info

    def render(self) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 from ManiSkill's render camera."""
        frame = self._env.render()
        return np.ascontiguousarray(to_numpy(frame)).astype(np.uint8)

    def get_state(self) -> np.ndarray:
        """Flat simulator state, as ManiSkill's `get_state()` (float32 values, as float64)."""
        return to_numpy(self.base.get_state()).astype(np.float64)

    def eef_position(self) -> np.ndarray:
        """The TCP's world position (3,) float64, metres (`proprio[:3]`)."""
        return to_numpy(self.base.agent.tcp.pose.p).astype(np.float64)

    def _close(self) -> None:
        self._env.close()

    # -----------------------------------------------------------------------------------------
    def _info(self, raw_info: dict) -> dict[str, Any]:
        info: dict[str, Any] = {"success": bool(to_numpy(raw_info["success"]))}
        for key, value in raw_info.items():
            if key.startswith("is_"):
                info[key] = bool(to_numpy(value))
        return info

    def _make_obs(self, raw: Any) -> dict[str, np.ndarray]:
        obs = {"proprio": proprio_features(self.base),
               "object": object_features(self.name, self.base)}
        if self.obs_kind in ("rgb", "rgbd"):
            cams = raw["sensor_data"]
            obs["rgb"] = np.stack([to_numpy(cams[c]["rgb"]) for c in self.cameras]).astype(np.uint8)
            if self.obs_kind == "rgbd":
                depth = np.stack([to_numpy(cams[c]["depth"])[..., 0] for c in self.cameras])
                obs["depth"] = (depth.astype(np.float32) / 1000.0)  # millimetres -> metres
        return obs

    def __repr__(self) -> str:
        return f"ManiSkillEnv({self.name!r}, obs={self.obs_kind!r}, backend={self.sim_backend!r})"


make_maniskill_env = ManiSkillEnv
"""Build a ManiSkill task of the suite: `(name, obs="state", seed=0, **options)`."""
