"""The kitchen suite's environments: a robosuite `ManipulationEnv` per scene and a
`gymnasium.Env` around it with the project's observation dict (`icil_paper.sim.base.TaskEnv`).

Action (7-D in [-1, 1]), robosuite's OSC_POSE controller with delta input at 20 Hz, in the
robot base frame; the rotation an axis-angle vector applied on the left of the current
end-effector orientation::

    a = [dx, dy, dz,  rx, ry, rz,  g]
         x 0.05 m     x 0.5 rad    +1 closes, -1 opens

Observation (the same widths for every kitchen and Kinova task)::

    proprio (9,)  float32 = grip-site position (3) | quaternion x, y, z, w (4) | finger offsets (2)
    object  (18,) float32 = see `icil_paper.sim.kitchen.scenes`
    rgb     (2, H, W, 3) uint8     cameras agentview, robot0_eye_in_hand (obs="rgb"/"rgbd")
    depth   (2, H, W) float32      metres (obs="rgbd")

The finger offsets are the pads' signed distances from the grip site. The reward is 1.0 on
success steps, else 0.0.

The Kinova tasks, the sim-to-real stand-in, run the same fixtures on robosuite's `Kinova3` arm
under a "reality gap" drawn anew every episode (`RealityGap`): fixture damping, friction and
part mass scaled at random, and Gaussian noise on every observation entry.
"""

from __future__ import annotations

import contextlib
import logging
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from robosuite.controllers import load_composite_controller_config
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
from robosuite.models.arenas import TableArena
from robosuite.models.tasks import ManipulationTask

from icil_paper.registry import check_name
from icil_paper.sim.base import TaskEnv, observation_space, state_box
from icil_paper.sim.kitchen.scenes import Scene, make_scene
from icil_paper.sim.kitchen.tasks import (
    ALL_TASKS,
    CONTROL_FREQ,
    KITCHEN_PROPRIO_DIM,
    SCENE_DISTRIBUTIONS,
    KitchenTaskSpec,
)

CAMERAS = ("agentview", "robot0_eye_in_hand")
"""Cameras of image observations, in the order of the `rgb` / `depth` arrays."""
PROPRIO_LAYOUT = ((3, "metric"), (4, "unit"), (2, "metric"))
"""Kinds of the `proprio` entries, for the observation space (`icil_paper.sim.base.state_box`)."""
OBJECT_LAYOUT = ((1, "metric"), (3, "metric"), (4, "unit"), (3, "metric"), (4, "unit"),
                 (3, "metric"))
"""Kinds of the `object` entries (layout in `icil_paper.sim.kitchen.scenes`)."""
_DOWN_QUAT_XYZW = np.array([np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0])


@dataclass(frozen=True)
class RealityGap:
    """Per-episode perturbation of the Kinova tasks."""

    damping_scale: tuple[float, float] = (0.5, 2.0)
    """Range of the factor on the fixture joint's damping (sampled log-uniformly)."""
    friction_scale: tuple[float, float] = (0.5, 2.0)
    """Range of the factor on the fixture joint's friction loss (log-uniform)."""
    mass_scale: tuple[float, float] = (0.7, 1.5)
    """Range of the factor on the mass (and inertia) of the fixture's moving part (uniform)."""
    obs_noise_std: float = 0.002
    """Std of Gaussian noise added to every proprio and object entry (m or rad)."""


class DynamicsPerturbation:
    """Scales a fixture's joint damping, friction and part mass from their nominal values."""

    def __init__(self, gap: RealityGap):
        self.gap = gap
        self._nominal = None
        self.last_scales: dict[str, float] = {}

    def bind(self, sim, dof_ids: list[int], body_ids: list[int]) -> None:
        m = sim.model
        self.dof_ids, self.body_ids = list(dof_ids), list(body_ids)
        self._nominal = (m.dof_damping[self.dof_ids].copy(),
                         m.dof_frictionloss[self.dof_ids].copy(),
                         m.body_mass[self.body_ids].copy(), m.body_inertia[self.body_ids].copy())

    def apply(self, sim, rng: np.random.Generator) -> dict[str, float]:
        damping, friction, mass, inertia = self._nominal
        g = self.gap
        scales = {"damping": float(np.exp(rng.uniform(*np.log(g.damping_scale)))),
                  "friction": float(np.exp(rng.uniform(*np.log(g.friction_scale)))),
                  "mass": float(rng.uniform(*g.mass_scale))}
        m = sim.model
        m.dof_damping[self.dof_ids] = damping * scales["damping"]
        m.dof_frictionloss[self.dof_ids] = friction * scales["friction"]
        m.body_mass[self.body_ids] = mass * scales["mass"]
        m.body_inertia[self.body_ids] = inertia * scales["mass"]
        self.last_scales = scales
        return scales


class KitchenSceneEnv(ManipulationEnv):
    """A robosuite manipulation env: one robot at a counter with the fixtures of one `Scene`.

    Resets only re-sample the layout (`hard_reset=False`); robosuite's observables are off.
    """

    def __init__(self, scene: Scene, robot: str = "Panda", horizon: int = 200,
                 offscreen: bool = False, perturbation: DynamicsPerturbation | None = None,
                 seed: int | None = None):
        self.scene = scene
        self.perturbation = perturbation
        self.success_flag = False
        self.table_full_size = (0.8, 0.8, 0.05)
        self.table_offset = (0.0, 0.0, 0.8)
        super().__init__(
            robots=robot,
            controller_configs=load_composite_controller_config(controller="BASIC", robot=robot),
            gripper_types="default",
            initialization_noise="default",
            use_camera_obs=False,
            has_renderer=False,
            has_offscreen_renderer=offscreen,
            render_camera=None,
            control_freq=CONTROL_FREQ,
            lite_physics=True,
            horizon=horizon,
            ignore_done=True,
            hard_reset=False,
            camera_names=list(CAMERAS),
            renderer="mujoco",
            seed=seed,
        )

    # model ---------------------------------------------------------------------------------
    def _load_model(self):
        super()._load_model()
        robot_model = self.robots[0].robot_model
        robot_model.set_base_xpos(robot_model.base_xpos_offset["table"](self.table_full_size[0]))
        arena = TableArena(table_full_size=self.table_full_size, table_offset=self.table_offset)
        arena.set_origin([0, 0, 0])
        # Over the robot's right shoulder, looking at the counter: fixtures face the robot, so
        # robosuite's default agentview (in front of the table) would see their backs.
        arena.set_camera(camera_name="agentview", pos=[-0.45, -0.75, 1.55],
                         quat=_look_at_quat_wxyz([-0.45, -0.75, 1.55], [0.05, 0.0, 0.85]))
        self.model = ManipulationTask(mujoco_arena=arena,
                                      mujoco_robots=[r.robot_model for r in self.robots],
                                      mujoco_objects=self.scene.build())

    def _setup_references(self):
        super()._setup_references()
        self.scene.bind(self.sim)
        gripper = self.robots[0].gripper["right"]
        m = self.sim.model
        self.grip_site_id = m.site_name2id(gripper.important_sites["grip_site"])
        self.pad_geom_ids = (m.geom_name2id(gripper.important_geoms["left_fingerpad"][0]),
                             m.geom_name2id(gripper.important_geoms["right_fingerpad"][0]))
        if self.perturbation is not None and self.perturbation._nominal is None:
            self.perturbation.bind(self.sim, *self.scene.dynamics_handles())

    def _setup_observables(self):
        return OrderedDict()

    def _reset_internal(self):
        super()._reset_internal()
        self.scene.reset(self.sim, self.rng)
        if self.perturbation is not None:
            self.perturbation.apply(self.sim, self.rng)
        self.sim.forward()
        self.success_flag = False

    # task ----------------------------------------------------------------------------------
    def _check_success(self):
        return self.scene.success(self)

    def reward(self, action=None):
        self.success_flag = bool(self._check_success())
        return float(self.success_flag)

    # measurements --------------------------------------------------------------------------
    def eef_pos(self) -> np.ndarray:
        return np.array(self.sim.data.site_xpos[self.grip_site_id])

    def eef_mat(self) -> np.ndarray:
        return np.array(self.sim.data.site_xmat[self.grip_site_id]).reshape(3, 3)

    def proprio(self) -> np.ndarray:
        out = np.empty(KITCHEN_PROPRIO_DIM, dtype=np.float32)
        pos, mat = self.eef_pos(), self.eef_mat()
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, mat.reshape(-1))
        xyzw = np.array([quat[1], quat[2], quat[3], quat[0]])
        out[0:3] = pos
        out[3:7] = -xyzw if xyzw @ _DOWN_QUAT_XYZW < 0 else xyzw
        axis = mat[:, 0]
        left, right = (self.sim.data.geom_xpos[g] - pos for g in self.pad_geom_ids)
        out[7] = abs(float(left @ axis))
        out[8] = -abs(float(right @ axis))
        return out


def _look_at_quat_wxyz(eye, target) -> list[float]:
    """MuJoCo camera quaternion (w, x, y, z) looking from `eye` at `target`, z up."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    back = eye - target
    back /= np.linalg.norm(back)                     # camera +z points away from the scene
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    mat = np.stack([right, up, back], axis=1)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, mat.reshape(-1))
    return quat.tolist()


class KitchenEnv(TaskEnv):
    """A kitchen (or Kinova) task as a `gymnasium.Env`; `scenes` names the layouts'
    distribution. Layout, joint noise, Kinova perturbation and observation noise all follow
    from the episode's seed."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_FREQ}

    def __init__(self, name: str, obs: str = "state", seed: int = 0, camera_size: int = 84,
                 horizon: int | None = None, obs_noise_std: float | None = None,
                 render_mode: str | None = None, scenes: str = SCENE_DISTRIBUTIONS[0]):
        check_name("kitchen task", name, ALL_TASKS)
        self.task_spec: KitchenTaskSpec = ALL_TASKS[name]
        super().__init__(name, obs, seed, horizon=int(horizon or self.task_spec.horizon),
                         instruction=self.task_spec.instruction, render_mode=render_mode)
        self.camera_size = int(camera_size)
        self.cameras = CAMERAS if obs != "state" else ()
        gap = RealityGap() if self.task_spec.perturbed else None
        self.obs_noise_std = float(obs_noise_std if obs_noise_std is not None
                                   else (gap.obs_noise_std if gap else 0.0))
        self.scene = make_scene(self.task_spec.scene, self.task_spec.goal, scenes)
        self.scenes = self.scene.scenes
        with _quiet_robosuite():
            self._env = KitchenSceneEnv(self.scene, robot=self.task_spec.robot,
                                        horizon=self.horizon, offscreen=obs != "state",
                                        perturbation=DynamicsPerturbation(gap) if gap else None,
                                        seed=seed)
        self.sim = self._env.sim
        self._noise_rng = np.random.default_rng(0)
        extent = self.sim.model.stat.extent
        self.observation_space = observation_space(
            state_box(PROPRIO_LAYOUT, self.obs_noise_std),
            state_box(OBJECT_LAYOUT, self.obs_noise_std), obs,
            image=(len(self.cameras), self.camera_size, self.camera_size),
            depth_range=(0.0, float(self.sim.model.vis.map.zfar * extent) * (1 + 1e-4)))

    @property
    def geometry(self):
        """The scene's fixture geometry (fixture frame), for the scripted experts."""
        return self.scene.geometry

    @property
    def robosuite_env(self) -> KitchenSceneEnv:
        return self._env

    # gymnasium interface ----------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        self._begin_episode(seed)
        self._env.rng = self.np_random        # the layout, joint noise and perturbation
        self._noise_rng = np.random.default_rng([self.seed, 1])
        with _quiet_robosuite():                 # robosuite rebuilds its controllers here
            self._env.reset()
        return self._obs(), self._info(self._env.scene.success(self._env))

    def step(self, action):
        action = self._checked_action(action)
        _, reward, _, _ = self._env.step(action)
        success = self._env.success_flag
        terminated, truncated = self._step_outcome(success)
        return self._obs(), float(reward), terminated, truncated, self._info(success)

    def render(self, camera: str = "agentview", size: int | tuple[int, int] = 256) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 from a camera of the scene (at most 640 x 480)."""
        width, height = (size, size) if np.isscalar(size) else size
        if self.sim._render_context_offscreen is None:  # a state env has none yet
            from robosuite.utils.binding_utils import MjRenderContextOffscreen

            MjRenderContextOffscreen(self.sim, device_id=-1)
            self.sim._render_context_offscreen.vopt.geomgroup[0] = 0   # hide collision meshes
        rgb = self.sim.render(width=int(width), height=int(height), camera_name=camera)
        return np.ascontiguousarray(rgb[::-1])

    def get_state(self) -> np.ndarray:
        """Flat MuJoCo state (time, qpos, qvel) as float64, robomimic's `states` entry."""
        return np.asarray(self.sim.get_state().flatten(), dtype=np.float64)

    def eef_position(self) -> np.ndarray:
        """The grip site's world position (3,) float64, metres, without observation noise."""
        return self._env.eef_pos().astype(np.float64)

    def _close(self) -> None:
        self._env.close()

    # -----------------------------------------------------------------------------------------
    def _info(self, success: bool) -> dict[str, Any]:
        return {"success": bool(success), "joint_pos": self.scene.joint_pos(self.sim)}

    def _obs(self) -> dict[str, np.ndarray]:
        proprio = self._env.proprio()
        obj = self.scene.object_state(self.sim, proprio[:3].astype(np.float64))
        if self.obs_noise_std > 0:
            proprio = proprio + self._noise_rng.normal(0, self.obs_noise_std, proprio.shape)
            obj = obj + self._noise_rng.normal(0, self.obs_noise_std, obj.shape)
        out = {"proprio": proprio.astype(np.float32), "object": obj.astype(np.float32)}
        if self.obs_kind != "state":
            size, rgbd = self.camera_size, self.obs_kind == "rgbd"
            frames = [self.sim.render(width=size, height=size, camera_name=cam, depth=rgbd)
                      for cam in self.cameras]  # (rgb, depth) pairs for "rgbd"
            out["rgb"] = np.stack([(f[0] if rgbd else f)[::-1] for f in frames]).astype(np.uint8)
            if rgbd:
                out["depth"] = np.stack([_metric_depth(self.sim, f[1][::-1])
                                         for f in frames]).astype(np.float32)
        return out

    def __repr__(self) -> str:
        return f"KitchenEnv({self.name!r}, obs={self.obs_kind!r}, robot={self.task_spec.robot!r})"


@contextlib.contextmanager
def _quiet_robosuite():
    """Silence robosuite's notices about controller parts a single arm lacks."""
    logger = logging.getLogger("robosuite_logs")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _metric_depth(sim, depth: np.ndarray) -> np.ndarray:
    """MuJoCo's normalized depth buffer -> distances in metres."""
    extent = sim.model.stat.extent
    far, near = sim.model.vis.map.zfar * extent, sim.model.vis.map.znear * extent
    return near / (1.0 - depth * (1.0 - near / far))

