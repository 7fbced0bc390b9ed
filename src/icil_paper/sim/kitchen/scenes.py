"""Scenes of the kitchen suite: which fixture stands on the counter, where (per seed), and what
counts as success. A scene builds its fixture once and re-samples its layout on every reset.

The object-state vector (`object_state`, KITCHEN_OBJECT_DIM = 18, every kitchen and Kinova task)::

    [0]      joint position of the fixture's moving part (door: rad, drawer: m)
    [1:4]    key point position: the handle
    [4:8]    moving part orientation, quaternion x, y, z, w (sign: w >= 0)
    [8:11]   target position: the fixture's base
    [11:15]  target orientation, quaternion x, y, z, w (sign: w >= 0)
    [15:18]  key point minus end-effector position

Positions are world coordinates in metres (counter top at z = COUNTER_Z). Scene
distributions differ only in their `layouts`: `generated` (the default) and `human`
(cabinets further back and out, a wider yaw: the `human` source's scenes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from icil_paper.registry import check_name
from icil_paper.sim.kitchen import fixtures as fx
from icil_paper.sim.kitchen.tasks import KITCHEN_OBJECT_DIM, SCENE_DISTRIBUTIONS

COUNTER_Z = 0.8
"""Height of the counter (robosuite TableArena top) in metres."""


def yaw_quat_wxyz(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) -> (x, y, z, w) with w >= 0."""
    q = np.asarray(q, dtype=np.float64)
    out = np.array([q[1], q[2], q[3], q[0]])
    return -out if out[3] < 0 else out


def rot_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def quat_xyzw_to_yaw(q: np.ndarray) -> float:
    """Yaw (rotation about world z) of a body whose z axis stays vertical."""
    x, y, z, w = q
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


@dataclass(frozen=True)
class Box2:
    """A uniform sampling range per coordinate: x, y (m) and yaw (rad)."""

    x: tuple[float, float]
    y: tuple[float, float]
    yaw: tuple[float, float]

    def sample(self, rng: np.random.Generator) -> tuple[float, float, float]:
        return (float(rng.uniform(*self.x)), float(rng.uniform(*self.y)),
                float(rng.uniform(*self.yaw)))


class Scene:
    """A fixture with one joint on the counter; success is the joint passing a threshold."""

    builder = None
    layouts: dict[str, Box2]
    """Fixture position and yaw on the counter, per scene distribution."""
    init: dict[str, tuple[float, float]]
    """Initial joint range per goal."""
    threshold: dict[str, tuple[str, float]]
    """Per goal: (">=" or "<=", joint value) that counts as success."""
    name = "fixture"
    goal: str
    """The task's goal: a key of `init` and `threshold`."""
    scenes: str = SCENE_DISTRIBUTIONS[0]
    """The scene distribution its layouts are drawn from."""

    def __init__(self, goal: str, scenes: str = SCENE_DISTRIBUTIONS[0]):
        if goal not in self.init:
            raise ValueError(f"{type(self).__name__} has no goal {goal!r}; "
                             f"goals: {list(self.init)}")
        self.goal = goal
        self.scenes = check_name("scene distribution", scenes, SCENE_DISTRIBUTIONS)
        self.layout = self.layouts[scenes]
        self.fixture, self.geometry = type(self).builder(self.name)

    def build(self) -> list:
        return [self.fixture]

    def bind(self, sim) -> None:
        m = sim.model
        self.root_id = m.body_name2id(self.fixture.root_body)
        self.joint_name = f"{self.name}_joint"
        self.joint_id = m.joint_name2id(self.joint_name)
        self.qpos_addr = m.get_joint_qpos_addr(self.joint_name)
        self.dof_addr = m.get_joint_qvel_addr(self.joint_name)
        self.part_id = int(m._model.jnt_bodyid[self.joint_id])
        self.site_id = m.site_name2id(f"{self.name}_handle")

    def reset(self, sim, rng: np.random.Generator) -> None:
        x, y, yaw = self.layout.sample(rng)
        sim.model.body_pos[self.root_id] = (x, y, COUNTER_Z)
        sim.model.body_quat[self.root_id] = yaw_quat_wxyz(yaw)
        sim.data.qpos[self.qpos_addr] = rng.uniform(*self.init[self.goal])
        sim.data.qvel[self.dof_addr] = 0.0

    def object_state(self, sim, eef_pos: np.ndarray) -> np.ndarray:
        key_pos, key_quat = self.key_pose(sim)
        target_pos, target_quat = self.target_pose(sim)
        out = np.zeros(KITCHEN_OBJECT_DIM, dtype=np.float32)
        out[0] = self.joint_pos(sim)
        out[1:4] = key_pos
        out[4:8] = key_quat
        out[8:11] = target_pos
        out[11:15] = target_quat
        out[15:18] = key_pos - eef_pos
        return out

    def joint_pos(self, sim) -> float:
        return float(sim.data.qpos[self.qpos_addr])

    def key_pose(self, sim):
        return (np.array(sim.data.site_xpos[self.site_id]),
                wxyz_to_xyzw(sim.data.body_xquat[self.part_id]))

    def target_pose(self, sim):
        return (np.array(sim.data.body_xpos[self.root_id]),
                wxyz_to_xyzw(sim.data.body_xquat[self.root_id]))

    def reached(self, q: float) -> bool:
        op, value = self.threshold[self.goal]
        return q >= value if op == ">=" else q <= value

    def success(self, env) -> bool:
        return self.reached(self.joint_pos(env.sim))

    def dynamics_handles(self) -> tuple[list[int], list[int]]:
        """(dof ids, body ids) whose damping/friction and mass the Kinova tasks perturb."""
        return [self.dof_addr], [self.part_id]


class DoorScene(Scene):
    """Cabinet with a hinged door (angle 0 closed, 1.75 rad fully open). It stands left of the
    robot's centre line, so the opened door swings clear of the hand's start pose."""

    builder = staticmethod(fx.cabinet_with_door)
    name = "cabinet"
    layouts = {"generated": Box2(x=(0.12, 0.17), y=(0.02, 0.10), yaw=(-0.2, 0.2)),
               "human": Box2(x=(0.16, 0.22), y=(0.08, 0.17), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.05), "close": (0.9, 1.4)}
    threshold = {"open": (">=", 1.0), "close": ("<=", 0.08)}


class DrawerScene(Scene):
    """Cabinet with a sliding drawer (travel 0 closed, 0.18 m fully out)."""

    builder = staticmethod(fx.cabinet_with_drawer)
    name = "drawer_cabinet"
    layouts = {"generated": Box2(x=(0.09, 0.20), y=(-0.14, 0.14), yaw=(-0.4, 0.4)),
               "human": Box2(x=(0.16, 0.22), y=(-0.17, -0.03), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.01), "close": (0.12, 0.17)}
    threshold = {"open": (">=", 0.12), "close": ("<=", 0.015)}


SCENES = {"door": DoorScene, "drawer": DrawerScene}


def make_scene(scene: str, goal: str, scenes: str = SCENE_DISTRIBUTIONS[0]) -> Scene:
    """The scene of a task (`KitchenTaskSpec.scene`, `.goal`) on scene distribution `scenes`."""
    return SCENES[scene](goal, scenes)
