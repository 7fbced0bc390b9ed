"""The kitchen suite's task table: names, skill families, horizons, instructions.

The Panda tasks (`kitchen/{open,close}_{door,drawer}`) train Table V's policies; their
Kinova twins (`kinova/...`, perturbed dynamics and noisy observations) are rolled out on.
"""

from __future__ import annotations

from dataclasses import dataclass

from icil_paper.sim.suite import SKILL_FAMILIES

KITCHEN_PROPRIO_DIM = 9
"""Width of `proprio`: end-effector position 3, quaternion 4, finger offsets 2."""
KITCHEN_OBJECT_DIM = 18
"""Width of `object`, the same for every task (layout in `icil_paper.sim.kitchen.scenes`)."""


CONTROL_FREQ = 20
"""Control rate of every kitchen and Kinova task, Hz (robosuite's `control_freq`)."""

SCENE_DISTRIBUTIONS = ("generated", "human")
"""Named distributions a scene's layout is drawn from (the env option `scenes`), default first."""


@dataclass(frozen=True)
class KitchenTaskSpec:
    """One task of the kitchen suite."""

    name: str
    """Registry name, e.g. "kitchen/open_drawer"."""
    family: str
    """Skill family: one of the paper's RoboCasa columns (`SKILL_FAMILIES`)."""
    scene: str
    """Fixture scene that the task runs in: door or drawer."""
    goal: str
    """What the robot must achieve in the scene: open or close."""
    horizon: int
    """Maximum number of 20 Hz control steps of an episode (it is truncated there)."""
    instruction: str
    """Language instruction of the task."""
    robot: str = "Panda"
    """robosuite robot: "Panda" for the kitchen tasks, "Kinova3" for the sim-to-real stand-in."""
    perturbed: bool = False
    """Scale fixture dynamics per episode and add observation noise (the Kinova tasks)."""


_KITCHEN = (
    KitchenTaskSpec("kitchen/open_door", "Open/Close Doors", "door", "open", 250,
                    "open the cabinet door"),
    KitchenTaskSpec("kitchen/close_door", "Open/Close Doors", "door", "close", 250,
                    "close the cabinet door"),
    KitchenTaskSpec("kitchen/open_drawer", "Open/Close Drawers", "drawer", "open", 200,
                    "open the drawer"),
    KitchenTaskSpec("kitchen/close_drawer", "Open/Close Drawers", "drawer", "close", 200,
                    "close the drawer"),
)

KITCHEN_TASKS: dict[str, KitchenTaskSpec] = {t.name: t for t in _KITCHEN}
"""Kitchen tasks (Panda arm) by full name."""

KINOVA_HORIZONS = {"drawer": 250, "door": 300}
"""Horizons of the Kinova tasks: its arm settles about twice as slowly under the same OSC."""

KINOVA_TASKS: dict[str, KitchenTaskSpec] = {
    f"kinova/{goal}_{scene}": KitchenTaskSpec(
        f"kinova/{goal}_{scene}", KITCHEN_TASKS[f"kitchen/{goal}_{scene}"].family, scene, goal,
        KINOVA_HORIZONS[scene],
        KITCHEN_TASKS[f"kitchen/{goal}_{scene}"].instruction, robot="Kinova3", perturbed=True)
    for scene in ("drawer", "door") for goal in ("open", "close")
}
"""Sim-to-real stand-in (Kinova Gen3 arm, perturbed dynamics, noisy observations) by name."""

ALL_TASKS: dict[str, KitchenTaskSpec] = {**KITCHEN_TASKS, **KINOVA_TASKS}

TASK_FAMILIES: dict[str, tuple[str, ...]] = {
    family: names for family in SKILL_FAMILIES
    if (names := tuple(t.name for t in _KITCHEN if t.family == family))
}
"""Skill family -> kitchen task names, in the paper's column order."""
