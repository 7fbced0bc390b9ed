"""Kitchen fixtures built as MJCF in code: a cabinet with a hinged door and one with a sliding
drawer.

No asset files. In each fixture's own frame the origin is the centre of its footprint on
the counter, the front faces -x (towards the robot), z points up; sizes are in metres. The
moving part hangs off one joint named "joint"; a site named "handle" marks where the robot
hooks it. Geoms collide with the robot but not with each other, so the joint range is the
only stop. Each builder returns the fixture and its `FixtureGeometry`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from robosuite.models.objects import MujocoObject

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
