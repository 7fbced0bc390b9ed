"""Scenes of the kitchen suite: which fixtures stand on the counter, where (per seed), and what
counts as success.

A scene builds its MJCF objects once (`build`), binds to the simulator's ids once (`bind`) and
re-samples its layout on every reset (`reset`: fixture position and yaw on the counter, initial
joint position, free-object poses) by writing `model.body_pos` / `model.body_quat` and `qpos`,
so resets never rebuild the model.

The object-state vector (`object_state`, KITCHEN_OBJECT_DIM = 18 entries, the same layout for
every task)::

    [0]      joint position of the fixture's moving part (rad or m; 0 for pick_place, insertion)
    [1:4]    key point position: handle / lever tip / knob fin / button cap / the free object
    [4:8]    key part orientation, quaternion x, y, z, w (moving part or free object)
    [8:11]   target position: fixture base (articulated scenes), bin floor centre, hole top centre
    [11:15]  target orientation, quaternion x, y, z, w
    [15:18]  key point minus end-effector position

Quaternions are made unique by a sign convention (w >= 0) so that they do not flip between
steps. Positions are world coordinates in metres; the counter top is at z = COUNTER_Z.

Scene distributions. Every scene draws its layout from one of `SCENE_DISTRIBUTIONS` (the env
option `scenes`), with the same random draws in the same order, so only the ranges differ:

- `generated` (the default): our stand-in for MimicGen's scenes. Every data set of the
  `generated` source, the Kinova tasks' data sets of both sources (their suite offers no
  other) and every table but Table VI are drawn from it.
- `human`: our stand-in for the scenes of RoboCasa's human data set, which the paper's
  cross-dataset table (Table VI) transfers to and describes as having "sparser object
  arrangements". Each fixture stands elsewhere on the counter: the cabinets further back and
  further out to their side, the faucet, stove and appliance further from the robot and off
  the centre line, each turned over a wider range of yaw; the free object and its target lie
  further apart, with more open counter between them. The ranges overlap the generated
  ones only in part (each scene's `layouts`, or `object_layouts` and `target_layouts`),
  so a policy trained on generated scenes meets fixture poses it has seen few or none of.
  The `human` source's demonstrations are generated on it (`icil_paper.data.sources`).
  Every layout stays within the scripted experts' reach (their success on both
  distributions: `python -m icil_paper.data.experts --suites kitchen`, shown in chapter 4).

Where x is measured from the counter's centre towards the far edge (the robot's base is at
x = -0.56) and y to the robot's left; yaw turns a fixture anticlockwise seen from above.
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
    """Base class: one fixture (or fixture + free object) on the counter."""

    goal: str
    scenes: str = SCENE_DISTRIBUTIONS[0]
    """The scene distribution its layouts are drawn from (module docstring)."""

    def build(self) -> list:
        raise NotImplementedError

    def bind(self, sim) -> None:
        raise NotImplementedError

    def reset(self, sim, rng: np.random.Generator) -> None:
        raise NotImplementedError

    def success(self, env) -> bool:
        raise NotImplementedError

    def object_state(self, sim, eef_pos: np.ndarray) -> np.ndarray:
        q = self.joint_pos(sim)
        key_pos, key_quat = self.key_pose(sim)
        target_pos, target_quat = self.target_pose(sim)
        out = np.zeros(KITCHEN_OBJECT_DIM, dtype=np.float32)
        out[0] = q
        out[1:4] = key_pos
        out[4:8] = key_quat
        out[8:11] = target_pos
        out[11:15] = target_quat
        out[15:18] = key_pos - eef_pos
        return out

    def joint_pos(self, sim) -> float:
        return 0.0

    def key_pose(self, sim) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def target_pose(self, sim) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def dynamics_handles(self) -> tuple[list[int], list[int]]:
        """(dof ids, body ids) whose damping/friction and mass the Kinova tasks perturb."""
        return [], []


# ---------------------------------------------------------------------------------------------
# Articulated fixtures: door, drawer, lever, knob, button
# ---------------------------------------------------------------------------------------------

class ArticulatedScene(Scene):
    """A fixture with one joint; success is the joint passing a threshold."""

    builder = None
    layouts: dict[str, Box2]
    """Fixture position and yaw on the counter, per scene distribution."""
    init: dict[str, tuple[float, float]]
    """Initial joint range per goal."""
    threshold: dict[str, tuple[str, float]]
    """Per goal: (">=" or "<=", joint value) that counts as success."""
    name = "fixture"

    def __init__(self, goal: str, scenes: str = SCENE_DISTRIBUTIONS[0]):
        if goal not in self.init:
            raise ValueError(f"{type(self).__name__} has no goal {goal!r}; "
                             f"goals: {list(self.init)}")
        self.goal = goal
        self.scenes = check_name("scene distribution", scenes, SCENE_DISTRIBUTIONS)
        self.layout = self.layouts[scenes]
        self.fixture, self.geometry = type(self).builder(self.name)
        self._latched = False

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
        self._latched = False

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

    def dynamics_handles(self):
        return [self.dof_addr], [self.part_id]


class DoorScene(ArticulatedScene):
    """Cabinet with a hinged door (angle 0 closed, 1.75 rad fully open). It stands left of the
    robot's centre line, so the opened door swings clear of the hand's start pose."""

    builder = staticmethod(fx.cabinet_with_door)
    name = "cabinet"
    layouts = {"generated": Box2(x=(0.12, 0.17), y=(0.02, 0.10), yaw=(-0.2, 0.2)),
               "human": Box2(x=(0.16, 0.22), y=(0.08, 0.17), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.05), "close": (0.9, 1.4)}
    threshold = {"open": (">=", 1.0), "close": ("<=", 0.08)}


class DrawerScene(ArticulatedScene):
    """Cabinet with a sliding drawer (travel 0 closed, 0.18 m fully out)."""

    builder = staticmethod(fx.cabinet_with_drawer)
    name = "drawer_cabinet"
    layouts = {"generated": Box2(x=(0.09, 0.20), y=(-0.14, 0.14), yaw=(-0.4, 0.4)),
               "human": Box2(x=(0.16, 0.22), y=(-0.17, -0.03), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.01), "close": (0.12, 0.17)}
    threshold = {"open": (">=", 0.12), "close": ("<=", 0.015)}


class LeverScene(ArticulatedScene):
    """Faucet lever turning about a vertical post (0 off, 1.3 rad fully on)."""

    builder = staticmethod(fx.faucet_lever)
    name = "faucet"
    layouts = {"generated": Box2(x=(-0.04, 0.12), y=(-0.08, 0.16), yaw=(-0.4, 0.4)),
               "human": Box2(x=(0.06, 0.14), y=(-0.14, 0.0), yaw=(-0.35, 0.35))}
    init = {"on": (0.0, 0.1), "off": (0.9, 1.2)}
    threshold = {"on": (">=", 0.8), "off": ("<=", 0.15)}


class KnobScene(ArticulatedScene):
    """Stove knob twisting about the vertical axis (0 off, 1.6 rad fully on)."""

    builder = staticmethod(fx.stove_knob)
    name = "stove"
    layouts = {"generated": Box2(x=(-0.04, 0.10), y=(-0.14, 0.14), yaw=(-0.45, 0.45)),
               "human": Box2(x=(0.06, 0.16), y=(-0.18, 0.02), yaw=(-0.5, 0.5))}
    init = {"on": (0.0, 0.1), "off": (1.1, 1.5)}
    threshold = {"on": (">=", 1.0), "off": ("<=", 0.2)}


class ButtonScene(ArticulatedScene):
    """Spring button: success once it has been pushed down 8 of its 12 mm (latched, since the
    spring returns it when released)."""

    builder = staticmethod(fx.button_box)
    name = "appliance"
    layouts = {"generated": Box2(x=(-0.07, 0.13), y=(-0.20, 0.20), yaw=(-0.6, 0.6)),
               "human": Box2(x=(0.06, 0.16), y=(-0.02, 0.18), yaw=(-0.5, 0.5))}
    init = {"press": (0.0, 0.0)}
    threshold = {"press": ("<=", -0.008)}

    def success(self, env) -> bool:
        self._latched = self._latched or self.reached(self.joint_pos(env.sim))
        return self._latched


# ---------------------------------------------------------------------------------------------
# Free objects: pick and place, insertion
# ---------------------------------------------------------------------------------------------

class FreeObjectScene(Scene):
    """A free object on the counter and a static target fixture."""

    object_layouts: dict[str, Box2]
    """The free object's position (y: distance from the centre line, on a side drawn per
    episode) and yaw, per scene distribution."""
    target_layouts: dict[str, Box2]
    """The target's position (y: on the other side) and yaw, per scene distribution."""

    def _choose(self, scenes: str) -> None:
        self.scenes = check_name("scene distribution", scenes, SCENE_DISTRIBUTIONS)
        self.object_layout = self.object_layouts[scenes]
        self.target_layout = self.target_layouts[scenes]

    def bind(self, sim) -> None:
        m = sim.model
        self.obj_body_id = m.body_name2id(self.obj.root_body)
        self.obj_joint = self.obj.joints[0]
        self.target_root_id = m.body_name2id(self.target.root_body)
        self.target_site_id = m.site_name2id(f"{self.target.name}_handle")

    def build(self) -> list:
        return [self.target, self.obj]

    def reset(self, sim, rng: np.random.Generator) -> None:
        side = 1.0 if rng.random() < 0.5 else -1.0      # object on the left or on the right
        ox, oy, oyaw = self.object_layout.sample(rng)
        tx, ty, tyaw = self.target_layout.sample(rng)
        sim.model.body_pos[self.target_root_id] = (tx, -side * ty, COUNTER_Z)
        sim.model.body_quat[self.target_root_id] = yaw_quat_wxyz(tyaw)
        pos = (ox, side * oy, COUNTER_Z + self.obj_half_height + 0.001)
        sim.data.set_joint_qpos(self.obj_joint, np.concatenate([pos, yaw_quat_wxyz(oyaw)]))

    def key_pose(self, sim):
        return (np.array(sim.data.body_xpos[self.obj_body_id]),
                wxyz_to_xyzw(sim.data.body_xquat[self.obj_body_id]))

    def target_pose(self, sim):
        return (np.array(sim.data.site_xpos[self.target_site_id]),
                wxyz_to_xyzw(sim.data.body_xquat[self.target_root_id]))

    def object_in_target_frame(self, sim) -> np.ndarray:
        """Object centre in the target fixture's frame (origin on the counter)."""
        rel = sim.data.body_xpos[self.obj_body_id] - sim.data.body_xpos[self.target_root_id]
        return sim.data.body_xmat[self.target_root_id].reshape(3, 3).T @ rel


class PickPlaceScene(FreeObjectScene):
    """A small box on the counter and an open bin; success when the box rests inside the bin,
    the gripper has let go of it and the hand has moved `CLEAR` away from it (as RoboCasa's
    pick-and-place tasks ask the gripper to be far from the object): a demonstration then
    shows the hand opening and leaving, not only the last moment before it lets go."""

    CLEAR = 0.06
    """Distance (m) from the box's centre that the hand must reach after letting go."""

    object_layouts = {
        "generated": Box2(x=(-0.03, 0.01), y=(0.11, 0.15), yaw=(-0.2, 0.2)),
        "human": Box2(x=(-0.14, 0.0), y=(0.14, 0.24), yaw=(-np.pi / 4, np.pi / 4))}
    target_layouts = {"generated": Box2(x=(0.01, 0.05), y=(0.08, 0.12), yaw=(-0.1, 0.1)),
                      "human": Box2(x=(0.04, 0.14), y=(0.12, 0.2), yaw=(-0.5, 0.5))}
    obj_half = (0.02, 0.02, 0.025)

    def __init__(self, goal: str = "place", scenes: str = SCENE_DISTRIBUTIONS[0]):
        from robosuite.models.objects import BoxObject

        self.goal = goal
        self._choose(scenes)
        self.obj_half_height = self.obj_half[2]
        self.obj = BoxObject(name="box", size=self.obj_half, rgba=(0.85, 0.2, 0.15, 1.0),
                             friction=(1.2, 0.005, 0.0001), density=500)
        self.target, self.geometry = fx.bin_container("bin")

    def success(self, env) -> bool:
        local = self.object_in_target_frame(env.sim)
        inside = (np.all(np.abs(local[:2]) < self.geometry.inner_half - 0.01)
                  and local[2] < self.geometry.top)
        away = np.linalg.norm(env.eef_pos() - env.sim.data.body_xpos[self.obj_body_id])
        return bool(inside and not env.is_grasping(self.obj) and away > self.CLEAR)


class InsertionScene(FreeObjectScene):
    """An upright round peg and a block with a square hole; success when the peg is at least
    2 cm deep in the hole."""

    object_layouts = {"generated": Box2(x=(-0.03, 0.01), y=(0.11, 0.15), yaw=(0.0, 0.0)),
                      "human": Box2(x=(-0.14, 0.0), y=(0.14, 0.24), yaw=(0.0, 0.0))}
    target_layouts = {"generated": Box2(x=(0.01, 0.05), y=(0.08, 0.12), yaw=(-0.1, 0.1)),
                      "human": Box2(x=(0.04, 0.14), y=(0.12, 0.2), yaw=(-0.5, 0.5))}
    peg_radius, peg_half_height = 0.015, 0.04

    def __init__(self, goal: str = "insert", scenes: str = SCENE_DISTRIBUTIONS[0]):
        from robosuite.models.objects import CylinderObject

        self.goal = goal
        self._choose(scenes)
        self.obj_half_height = self.peg_half_height
        self.obj = CylinderObject(name="peg", size=(self.peg_radius, self.peg_half_height),
                                  rgba=(0.9, 0.75, 0.2, 1.0), friction=(1.2, 0.005, 0.0001),
                                  density=500)
        self.target, self.geometry = fx.hole_block("hole_block")

    def success(self, env) -> bool:
        local = self.object_in_target_frame(env.sim)
        centred = np.all(np.abs(local[:2]) < self.geometry.inner_half - self.peg_radius + 0.004)
        peg_bottom = local[2] - self.peg_half_height
        return bool(centred and peg_bottom < self.geometry.top - 0.02)


SCENES = {"pick_place": PickPlaceScene, "door": DoorScene, "drawer": DrawerScene,
          "lever": LeverScene, "knob": KnobScene, "insertion": InsertionScene,
          "button": ButtonScene}


def make_scene(scene: str, goal: str, scenes: str = SCENE_DISTRIBUTIONS[0]) -> Scene:
    """The scene of a task (`KitchenTaskSpec.scene`, `.goal`) drawing its layouts from the
    scene distribution `scenes` (module docstring)."""
    return SCENES[scene](goal, scenes)
