"""The Meta-World suite's task table: names, instructions, horizons, skill families, ML45.

Every one of Meta-World's 50 v3 tasks is a task `metaworld/<task>`; thirteen stand in for
the paper's seven RoboCasa skill families (`TASK_FAMILIES`)::

    Pick and Place      pick-place, pick-place-wall     grasp an object, carry it, release
    Open/Close Doors    door-open, door-close           swing a hinged door
    Open/Close Drawers  drawer-open, drawer-close       slide a drawer by its handle
    Turning Levers      faucet-open, faucet-close       RoboCasa's levers are sink faucets
    Twisting Knobs      dial-turn                       turn a knob about its axis
    Insertion           peg-insert-side, coffee-push    RoboCasa's insertion puts a mug under
                                                        the coffee machine
    Pressing Buttons    button-press, coffee-button     RoboCasa presses appliance buttons

The zero-shot split is Meta-World's ML45 (`ZERO_SHOT_SPLIT`); the held-out tasks' families
are in `ALL_TASK_FAMILIES`.
"""

from __future__ import annotations

from dataclasses import dataclass

from icil_paper.benchmark_tasks import ML45_HELD_OUT, ML45_TRAIN, SKILL_FAMILIES
from icil_paper.registry import check_name

PREFIX = "metaworld"
PROPRIO_DIM = 8
"""Width of `proprio`: hand xyz and gripper opening, now and one step before (env.py)."""
OBJECT_DIM = 31
"""Width of `object`: both objects' poses now (14) and one step before (14), goal xyz (3)."""
CONTROL_FREQ = 80
"""Control rate, Hz: Meta-World's frame_skip 5 of a 2.5 ms timestep (env.py checks it)."""
DEFAULT_HORIZON = 200
"""Control steps of an episode for most tasks (others: the smallest multiple of 100 at least
1.1 times their expert's 99th-percentile length, from `python -m tools.metaworld_experts`)."""

HAND_SHIFT = 0.05
"""Metres: the largest shift per axis of the hand's start in `human` scenes (most tasks)."""

OUTER = 0.2
"""Fraction of each layout coordinate's range, at either end, that `human` scenes draw from."""

SCENE_DISTRIBUTIONS = ("generated", "human")
"""Named distributions a layout is drawn from (the env option `scenes`), default first."""

FAMILIES = SKILL_FAMILIES
"""The seven skill families, in the column order of the paper's RoboCasa tables."""


@dataclass(frozen=True)
class MetaWorldTaskSpec:
    """One task of the Meta-World suite."""

    name: str
    """Registry name, `metaworld/<task>`, e.g. "metaworld/drawer-open"."""
    env_name: str
    """Meta-World's name of the task without the version, e.g. "drawer-open"."""
    instruction: str
    """Language instruction of the task."""
    family: str | None = None
    """Skill family of `FAMILIES` the task stands in for, or None."""
    horizon: int = DEFAULT_HORIZON
    """Maximum number of control steps of an episode (it is truncated there)."""
    hand_shift: float = HAND_SHIFT
    """Metres: the largest shift per axis of the hand's start in `human` scenes."""
    outer: float = OUTER
    """Fraction of each layout coordinate's range, at either end, that `human` scenes draw from."""

    @property
    def metaworld_id(self) -> str:
        """Meta-World's v3 name, e.g. "drawer-open-v3"."""
        return f"{self.env_name}-v3"


def _spec(env_name: str, instruction: str, family: str | None = None,
          **fields) -> MetaWorldTaskSpec:
    return MetaWorldTaskSpec(f"{PREFIX}/{env_name}", env_name, instruction, family, **fields)


# The 13 tasks of the RoboCasa families first (in family order), then the rest in Meta-World's
# order (`metaworld.env_dict.ALL_V3_ENVIRONMENTS`); the held-out ML45 tasks carry the family
# of the zero-shot table.
_TASKS = (
    _spec("pick-place", "pick up the puck and place it at the goal", "Pick and Place"),
    _spec("pick-place-wall", "pick up the puck and place it at the goal behind the wall",
          "Pick and Place"),
    # door-open and peg-insert-side: their experts fail from a shifted start and at an edge
    # of the layout box (a door at its low-x, low-y corner, a box at its far y edge)
    _spec("door-open", "open the door", "Open/Close Doors", hand_shift=0.0, outer=0.35),
    _spec("door-close", "close the door", "Open/Close Doors"),
    _spec("drawer-open", "open the drawer", "Open/Close Drawers"),
    _spec("drawer-close", "close the drawer", "Open/Close Drawers"),
    _spec("faucet-open", "turn the faucet on", "Turning Levers"),
    _spec("faucet-close", "turn the faucet off", "Turning Levers"),
    _spec("dial-turn", "turn the dial", "Twisting Knobs"),
    _spec("peg-insert-side", "insert the peg into the hole from the side", "Insertion",
          horizon=300, hand_shift=0.0, outer=0.35),
    _spec("coffee-push", "push the mug under the coffee machine", "Insertion"),
    _spec("button-press", "press the button", "Pressing Buttons"),
    _spec("coffee-button", "press the button on the coffee machine", "Pressing Buttons"),
    _spec("assembly", "put the nut on the peg"),
    _spec("basketball", "put the ball into the basket", horizon=300, hand_shift=0.0),
    _spec("bin-picking", "move the puck from one bin to the other", "Pick and Place",
          horizon=300),
    _spec("box-close", "put the lid on the box", "Open/Close Doors", hand_shift=0.0),
    _spec("button-press-topdown", "press the button from the top"),
    _spec("button-press-topdown-wall", "press the button from the top behind the wall"),
    _spec("button-press-wall", "press the button behind the wall"),
    _spec("coffee-pull", "pull the mug away from the coffee machine"),
    _spec("disassemble", "take the nut off the peg", horizon=300),
    _spec("door-lock", "lock the door by turning the lock", "Twisting Knobs", horizon=400),
    _spec("door-unlock", "unlock the door by turning the lock", "Twisting Knobs"),
    _spec("hand-insert", "push the block into the hole", "Insertion"),
    _spec("hammer", "hammer the nail into the wall"),
    _spec("handle-press-side", "press the handle down from the side"),
    _spec("handle-press", "press the handle down"),
    _spec("handle-pull-side", "pull the handle up from the side"),
    _spec("handle-pull", "pull the handle up"),
    _spec("lever-pull", "pull the lever up", horizon=500),
    _spec("pick-out-of-hole", "pick the peg out of the hole"),
    _spec("plate-slide", "slide the plate into the cabinet"),
    _spec("plate-slide-side", "slide the plate into the cabinet from the side"),
    _spec("plate-slide-back", "slide the plate out of the cabinet"),
    _spec("plate-slide-back-side", "slide the plate out of the cabinet to the side"),
    _spec("peg-unplug-side", "unplug the peg to the side"),
    _spec("soccer", "kick the ball into the goal"),
    _spec("stick-push", "push the thermos with the stick"),
    _spec("stick-pull", "pull the thermos with the stick", horizon=500),
    _spec("push", "push the puck to the goal"),
    _spec("push-wall", "push the puck around the wall to the goal"),
    _spec("push-back", "pull the puck back to the goal", horizon=500),
    _spec("reach", "reach the goal"),
    _spec("reach-wall", "reach the goal behind the wall"),
    _spec("shelf-place", "place the puck on the shelf", horizon=300),
    _spec("sweep-into", "sweep the puck into the hole"),
    _spec("sweep", "sweep the puck off the table"),
    _spec("window-open", "slide the window open"),
    _spec("window-close", "slide the window closed"),
)

METAWORLD_TASKS: dict[str, MetaWorldTaskSpec] = {t.name: t for t in _TASKS}
"""Every Meta-World v3 task by full name: the 13 of the RoboCasa families first."""
TASKS = tuple(METAWORLD_TASKS)

ZERO_SHOT_SPLIT = {"train": ML45_TRAIN, "held_out": ML45_HELD_OUT}
"""The suite's zero-shot split (the Suite record's `zero_shot_split`): Meta-World's ML45."""

TASK_FAMILIES: dict[str, tuple[str, ...]] = {
    family: tuple(t.name for t in _TASKS if t.family == family and t.name in ML45_TRAIN)
    for family in FAMILIES
}
"""Skill family (the paper's table column) -> the 13 Meta-World tasks of the RoboCasa tables
standing in for it."""
ROBOCASA_TASKS = tuple(task for tasks in TASK_FAMILIES.values() for task in tasks)
"""The 13 tasks of `TASK_FAMILIES`, in family order."""
ALL_TASK_FAMILIES: dict[str, tuple[str, ...]] = {
    family: tuple(t.name for t in _TASKS if t.family == family) for family in FAMILIES
}
"""Skill family -> every task with that family: `TASK_FAMILIES`' and the held-out ML45 tasks'
(the zero-shot table's columns); the suite record's `families`."""


def family_of(task: str) -> str | None:
    """The skill family a Meta-World task stands in for (held-out ML45 tasks included)."""
    return METAWORLD_TASKS[check_name("Meta-World task", task, TASKS)].family
