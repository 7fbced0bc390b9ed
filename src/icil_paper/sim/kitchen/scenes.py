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

The fixtures, a cabinet with a hinged door and one with a sliding drawer, are MJCF built in
code (no asset files). In each fixture's own frame the origin is the centre of its footprint
on the counter, the front faces -x (towards the robot), z points up; sizes are in metres.
The moving part hangs off one joint named "joint"; a site named "handle" marks where the
robot hooks it. Geoms collide with the robot but not with each other, so the joint range is
the only stop. Each builder returns the fixture and its `FixtureGeometry`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from robosuite.models.objects import MujocoObject

from icil_paper.registry import check_name
from icil_paper.sim.kitchen.tasks import KITCHEN_OBJECT_DIM, SCENE_DISTRIBUTIONS

COUNTER_Z = 0.8
"""Height of the counter (robosuite TableArena top) in metres."""


WOOD = (0.62, 0.45, 0.30, 1.0)
DARK_WOOD = (0.42, 0.28, 0.18, 1.0)
STEEL = (0.70, 0.72, 0.75, 1.0)


def _fmt(values) -> str:
    return " ".join(f"{float(v):.5g}" for v in np.atleast_1d(values))


class _Builder:
    """Appends geoms, bodies, joints and sites to an ET body with short keyword calls."""

    def __init__(self):
        self.count = 0

    def geom(self, body: ET.Element, kind: str, size, pos=(0, 0, 0), rgba=WOOD,
             name: str | None = None, **attrs) -> ET.Element:
        self.count += 1
        attrib = {"name": name or f"g{self.count}", "type": kind, "size": _fmt(size),
                  "pos": _fmt(pos), "rgba": _fmt(rgba), "group": "1", "contype": "2",
                  "conaffinity": "1", "friction": "1 0.005 0.0001", "solref": "0.01 1"}
        attrib.update({k: (v if isinstance(v, str) else _fmt(v)) for k, v in attrs.items()})
        return ET.SubElement(body, "geom", attrib=attrib)

    def box(self, body, half, pos=(0, 0, 0), rgba=WOOD, **attrs):
        return self.geom(body, "box", half, pos, rgba, **attrs)

    @staticmethod
    def body(parent: ET.Element, name: str, pos=(0, 0, 0), **attrs) -> ET.Element:
        attrib = {"name": name, "pos": _fmt(pos)}
        attrib.update({k: (v if isinstance(v, str) else _fmt(v)) for k, v in attrs.items()})
        return ET.SubElement(parent, "body", attrib=attrib)

    @staticmethod
    def inertial(body: ET.Element, mass: float, pos, half) -> ET.Element:
        """Explicit inertia of a solid box of half sizes `half` (fixture geoms are group 1,
        from which robosuite's compiler takes no inertia)."""
        hx, hy, hz = half
        diag = (mass / 3 * (hy**2 + hz**2), mass / 3 * (hx**2 + hz**2), mass / 3 * (hx**2 + hy**2))
        return ET.SubElement(body, "inertial", attrib={"pos": _fmt(pos), "mass": _fmt(mass),
                                                       "diaginertia": _fmt(diag)})

    @staticmethod
    def joint(body: ET.Element, kind: str, axis, limits, damping: float, frictionloss: float,
              pos=(0, 0, 0), **attrs) -> ET.Element:
        attrib = {"name": "joint", "type": kind, "axis": _fmt(axis), "pos": _fmt(pos),
                  "limited": "true", "range": _fmt(limits), "damping": _fmt(damping),
                  "frictionloss": _fmt(frictionloss), "armature": "0.005"}
        attrib.update({k: (v if isinstance(v, str) else _fmt(v)) for k, v in attrs.items()})
        return ET.SubElement(body, "joint", attrib=attrib)

    @staticmethod
    def site(body: ET.Element, name: str, pos=(0, 0, 0), size=0.006) -> ET.Element:
        return ET.SubElement(body, "site", attrib={
            "name": name, "pos": _fmt(pos), "size": _fmt(size), "rgba": "1 0 0 0",
            "type": "sphere", "group": "0"})


class CodeFixture(MujocoObject):
    """A robosuite `MujocoObject` whose body tree (`root`, named "main") was generated in code."""

    def __init__(self, name: str, root: ET.Element, half_extent: tuple[float, float, float]):
        super().__init__(obj_type="all", duplicate_collision_geoms=False)
        self._name = name
        self._half_extent = np.asarray(half_extent, dtype=float)
        self._obj = root
        self._get_object_properties()

    def _get_object_subtree(self):
        return self._obj

    def exclude_from_prefixing(self, inp):
        return False

    @property
    def bottom_offset(self):
        return np.zeros(3)

    @property
    def top_offset(self):
        return np.array([0.0, 0.0, 2 * self._half_extent[2]])

    @property
    def horizontal_radius(self):
        return float(np.linalg.norm(self._half_extent[:2]))

    def get_bounding_box_half_size(self):
        return self._half_extent.copy()


@dataclass(frozen=True)
class FixtureGeometry:
    """Numbers of one fixture that a scripted expert or a success check needs (fixture frame)."""

    joint_range: tuple[float, float] = (0.0, 0.0)
    """Limits of the fixture's joint (rad or m)."""
    joint_kind: str = "none"
    """"hinge" (door) or "slide" (drawer)."""
    joint_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    """Joint axis in the fixture frame."""
    pivot: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Hinge axis point (door) or the drawer's closed front (drawer), fixture frame."""
    hook: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where the closed fingertips sit to move the part, in the moving part's frame at joint 0."""
    top: float = 0.0
    """Height of the highest point of the fixture above the counter."""


def cabinet_with_door(name: str = "door_cabinet") -> tuple[CodeFixture, FixtureGeometry]:
    """A counter-top cabinet whose door swings towards the robot about a vertical hinge on
    its +y edge (angle 0 closed); a handle bar 5.5 cm off the door is hooked from above."""
    b = _Builder()
    depth, width, height, wall, door_t = 0.18, 0.26, 0.22, 0.01, 0.015
    root = ET.Element("body", attrib={"name": "main"})
    hx, hy = depth / 2, width / 2
    b.box(root, (hx, hy, wall / 2), (0, 0, wall / 2), WOOD)                      # floor
    b.box(root, (hx, hy, wall / 2), (0, 0, height - wall / 2), WOOD)             # top
    for s in (-1, 1):                                                              # sides
        b.box(root, (hx, wall / 2, height / 2), (0, s * (hy - wall / 2), height / 2), WOOD)
    b.box(root, (wall / 2, hy, height / 2), (hx - wall / 2, 0, height / 2), WOOD)  # back
    hinge = (-hx - door_t / 2 - 0.002, hy, 0.0)
    door = b.body(root, "door", hinge)
    door_w, door_h = width - 0.004, height - 0.004
    b.inertial(door, 0.7, (0, -door_w / 2, height / 2), (door_t / 2, door_w / 2, door_h / 2))
    b.joint(door, "hinge", (0, 0, -1), (0.0, 1.75), damping=0.3, frictionloss=0.15)
    b.box(door, (door_t / 2, door_w / 2, door_h / 2), (0, -door_w / 2, height / 2), DARK_WOOD)
    bar_z, bar_x, bar_y, bar_half = height - 0.022, -0.055, -door_w + 0.075, 0.045
    b.geom(door, "capsule", (0.007, bar_half), (bar_x, bar_y, bar_z), STEEL,
           quat="0.7071 0.7071 0 0")
    for s in (-1, 1):
        b.box(door, (abs(bar_x) / 2, 0.005, 0.006), (bar_x / 2, bar_y + s * bar_half, bar_z), STEEL)
    hook = (-(door_t / 2 + (abs(bar_x) - 0.007 - door_t / 2) / 2), bar_y, bar_z - 0.012)
    b.site(door, "handle", hook)
    geometry = FixtureGeometry(joint_range=(0.0, 1.75), joint_kind="hinge",
                               joint_axis=(0, 0, -1), pivot=hinge, hook=hook, top=height)
    return CodeFixture(name, root, (hx + 0.06, hy, height / 2)), geometry


def cabinet_with_drawer(name: str = "drawer_cabinet") -> tuple[CodeFixture, FixtureGeometry]:
    """A counter-top cabinet with one drawer that slides out towards the robot (-x); travel
    in metres, 0 closed; a handle bar 5.5 cm in front is hooked from above."""
    b = _Builder()
    depth, width, height, wall, front_t = 0.22, 0.28, 0.14, 0.01, 0.015
    root = ET.Element("body", attrib={"name": "main"})
    hx, hy = depth / 2, width / 2
    b.box(root, (hx, hy, wall / 2), (0, 0, wall / 2), WOOD)
    b.box(root, (hx, hy, wall / 2), (0, 0, height - wall / 2), WOOD)
    for s in (-1, 1):
        b.box(root, (hx, wall / 2, height / 2), (0, s * (hy - wall / 2), height / 2), WOOD)
    b.box(root, (wall / 2, hy, height / 2), (hx - wall / 2, 0, height / 2), WOOD)
    front_x = -hx - front_t / 2 - 0.002
    drawer = b.body(root, "drawer", (front_x, 0, 0))
    inner_d, inner_w, inner_h = depth - 0.03, width - 2 * wall - 0.01, height - 2 * wall - 0.02
    b.inertial(drawer, 0.7, (inner_d / 2, 0, height / 2), (inner_d / 2, inner_w / 2, inner_h / 2))
    b.joint(drawer, "slide", (-1, 0, 0), (0.0, 0.18), damping=3.0, frictionloss=0.8)
    b.box(drawer, (front_t / 2, hy - 0.002, height / 2 - 0.002), (0, 0, height / 2), DARK_WOOD)
    b.box(drawer, (inner_d / 2, inner_w / 2, 0.004), (inner_d / 2, 0, wall + 0.006), WOOD)
    for s in (-1, 1):
        b.box(drawer, (inner_d / 2, 0.004, inner_h / 2), (inner_d / 2, s * inner_w / 2,
                                                          wall + 0.006 + inner_h / 2), WOOD)
    b.box(drawer, (0.004, inner_w / 2, inner_h / 2), (inner_d, 0, wall + 0.006 + inner_h / 2), WOOD)
    bar_z, bar_x, bar_half = height - 0.022, -0.055, 0.06
    b.geom(drawer, "capsule", (0.007, bar_half), (bar_x, 0, bar_z), STEEL, quat="0.7071 0.7071 0 0")
    for s in (-1, 1):
        b.box(drawer, (abs(bar_x) / 2, 0.005, 0.006), (bar_x / 2, s * bar_half, bar_z), STEEL)
    hook = (-(front_t / 2 + (abs(bar_x) - 0.007 - front_t / 2) / 2), 0.0, bar_z - 0.012)
    b.site(drawer, "handle", hook)
    pivot = (front_x, 0.0, 0.0)
    geometry = FixtureGeometry(joint_range=(0.0, 0.18), joint_kind="slide",
                               joint_axis=(-1, 0, 0), pivot=pivot, hook=hook, top=height)
    return CodeFixture(name, root, (hx + 0.06, hy, height / 2)), geometry


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

    builder = staticmethod(cabinet_with_door)
    name = "cabinet"
    layouts = {"generated": Box2(x=(0.12, 0.17), y=(0.02, 0.10), yaw=(-0.2, 0.2)),
               "human": Box2(x=(0.16, 0.22), y=(0.08, 0.17), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.05), "close": (0.9, 1.4)}
    threshold = {"open": (">=", 1.0), "close": ("<=", 0.08)}


class DrawerScene(Scene):
    """Cabinet with a sliding drawer (travel 0 closed, 0.18 m fully out)."""

    builder = staticmethod(cabinet_with_drawer)
    name = "drawer_cabinet"
    layouts = {"generated": Box2(x=(0.09, 0.20), y=(-0.14, 0.14), yaw=(-0.4, 0.4)),
               "human": Box2(x=(0.16, 0.22), y=(-0.17, -0.03), yaw=(-0.1, 0.35))}
    init = {"open": (0.0, 0.01), "close": (0.12, 0.17)}
    threshold = {"open": (">=", 0.12), "close": ("<=", 0.015)}


SCENES = {"door": DoorScene, "drawer": DrawerScene}


def make_scene(scene: str, goal: str, scenes: str = SCENE_DISTRIBUTIONS[0]) -> Scene:
    """The scene of a task (`KitchenTaskSpec.scene`, `.goal`) on scene distribution `scenes`."""
    return SCENES[scene](goal, scenes)
