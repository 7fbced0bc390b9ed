"""The kitchen suite's task table: names, skill families, horizons, instructions, splits.

This module imports nothing heavy (no robosuite), so `icil_paper.sim.kitchen` can list its tasks
cheaply. The suite stands in for RoboCasa's seven foundational skill families (its assets and
data sets cannot be downloaded here): each family becomes one or two robosuite tasks on a
counter with fixtures built in code (`fixtures.py`).

Families and tasks (the columns of the paper's RoboCasa tables)::

    Pick and Place      kitchen/pick_place
    Open/Close Doors    kitchen/open_door       kitchen/close_door
    Open/Close Drawers  kitchen/open_drawer     kitchen/close_drawer
    Turning Levers      kitchen/turn_lever_on   kitchen/turn_lever_off
    Twisting Knobs      kitchen/twist_knob_on   kitchen/twist_knob_off
    Insertion           kitchen/insertion
    Pressing Buttons    kitchen/press_button

The Kinova tasks (`kinova/...`) are the suite's stand-in for the paper's sim-to-real table
(Kinova Gen3, Table "Sim-to-real success rates"): the door and drawer tasks on robosuite's
Kinova3 arm with its Robotiq 2F-85 gripper, fixture dynamics (joint damping, friction, part
masses) scaled at random per episode and Gaussian noise on the observations, standing in for
the reality gap (see `kinova.py`). They have the same observation widths as the Panda tasks.
"""

from __future__ import annotations

from dataclasses import dataclass

KITCHEN_PROPRIO_DIM = 9
"""Width of `proprio`: end-effector position 3, quaternion 4, finger offsets 2."""
KITCHEN_OBJECT_DIM = 18
"""Width of `object`, the same for every task (layout in `icil_paper.sim.kitchen.scenes`)."""


CONTROL_FREQ = 20
"""Control rate of every kitchen and Kinova task, Hz (robosuite's `control_freq`)."""

SCENE_DISTRIBUTIONS = ("generated", "human")
"""Named distributions a scene's layout is drawn from (the env option `scenes`; the first is
the default): `generated`, our stand-in for MimicGen's scenes, and `human`, for those of
RoboCasa's human data set (the layouts are in `icil_paper.sim.kitchen.scenes`)."""

@dataclass(frozen=True)
class KitchenTaskSpec:
    """One task of the kitchen suite."""

    name: str
    """Registry name, e.g. "kitchen/open_drawer"."""
    family: str
    """Skill family: one of the seven columns of the paper's RoboCasa table."""
    scene: str
    """Fixture scene that the task runs in: pick_place, door, drawer, lever, knob, insertion,
    button."""
    goal: str
    """What the robot must achieve in the scene: place, open, close, on, off, insert, press."""
    horizon: int
    """Maximum number of 20 Hz control steps of an episode (it is truncated there)."""
    instruction: str
    """Language instruction of the task."""
    robot: str = "Panda"
    """robosuite robot: "Panda" for the kitchen tasks, "Kinova3" for the sim-to-real stand-in."""
    perturbed: bool = False
    """Scale fixture dynamics per episode and add observation noise (the Kinova tasks)."""


FAMILIES = ("Pick and Place", "Open/Close Doors", "Open/Close Drawers", "Turning Levers",
            "Twisting Knobs", "Insertion", "Pressing Buttons")
"""The seven skill families, in the column order of the paper's RoboCasa tables."""

_KITCHEN = (
    KitchenTaskSpec("kitchen/pick_place", "Pick and Place", "pick_place", "place", 300,
                    "pick the box from the counter and place it in the bin"),
    KitchenTaskSpec("kitchen/open_door", "Open/Close Doors", "door", "open", 250,
                    "open the cabinet door"),
    KitchenTaskSpec("kitchen/close_door", "Open/Close Doors", "door", "close", 250,
                    "close the cabinet door"),
    KitchenTaskSpec("kitchen/open_drawer", "Open/Close Drawers", "drawer", "open", 200,
                    "open the drawer"),
    KitchenTaskSpec("kitchen/close_drawer", "Open/Close Drawers", "drawer", "close", 200,
                    "close the drawer"),
    KitchenTaskSpec("kitchen/turn_lever_on", "Turning Levers", "lever", "on", 200,
                    "turn the faucet lever on"),
    KitchenTaskSpec("kitchen/turn_lever_off", "Turning Levers", "lever", "off", 200,
                    "turn the faucet lever off"),
    KitchenTaskSpec("kitchen/twist_knob_on", "Twisting Knobs", "knob", "on", 250,
                    "twist the stove knob to turn the burner on"),
    KitchenTaskSpec("kitchen/twist_knob_off", "Twisting Knobs", "knob", "off", 250,
                    "twist the stove knob to turn the burner off"),
    KitchenTaskSpec("kitchen/insertion", "Insertion", "insertion", "insert", 300,
                    "insert the peg into the hole"),
    KitchenTaskSpec("kitchen/press_button", "Pressing Buttons", "button", "press", 150,
                    "press the button on the appliance"),
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
    family: tuple(t.name for t in _KITCHEN if t.family == family) for family in FAMILIES
}
"""Skill family (the paper's table column) -> kitchen task names."""

KITCHEN_ZERO_SHOT_SPLIT: dict[str, tuple[str, ...]] = {
    "train": ("kitchen/pick_place", "kitchen/open_door", "kitchen/close_drawer",
              "kitchen/turn_lever_on", "kitchen/twist_knob_off", "kitchen/insertion",
              "kitchen/press_button"),
    "test": ("kitchen/close_door", "kitchen/open_drawer", "kitchen/turn_lever_off",
             "kitchen/twist_knob_on"),
}
"""Zero-shot split (the paper's zero-shot table; RoboCasa trains on some atomic tasks and tests
on the rest). One task of each two-task family is held out, so every test task is a new motion
on a fixture seen in training (close a door the policy has only opened, open a drawer it has
only closed, ...). The held-out direction alternates between families so that training still
sees both opening and closing motions. Pick and Place, Insertion and Pressing Buttons have one
task each and stay in training; their zero-shot columns have no test task in this suite."""
