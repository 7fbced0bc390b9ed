"""The ManiSkill suite (as `sim/kitchen/` is the kitchen's): PickCube, PushCube and StackCube
of ManiSkill 3 on the Panda arm, registered as the `maniskill` suite.

    from icil_paper.sim import make_env, make_expert
    env = make_env("maniskill/pick_cube", obs="state")   # a ManiSkillEnv (`env.py`)
    expert = make_expert("maniskill/pick_cube")          # its motion planner (`expert.py`)

Listing the suite imports neither ManiSkill nor SAPIEN; building an env or an expert does.
"""

from __future__ import annotations

import importlib.util

from icil_paper.sim.maniskill.env import (
    CONTROL_FREQ,
    MANISKILL_OBS_DIMS,
    MANISKILL_TASKS,
    ManiSkillEnv,
    make_maniskill_env,
    vulkan_skip_reason,
)
from icil_paper.sim.suite import Suite


def make_maniskill_expert(name: str):
    """The task's motion-planning expert (`expert.py`)."""
    return __getattr__("MotionPlanningExpert")(name)


def __getattr__(attr: str):
    # PEP 562: the motion-planning experts (scipy, ManiSkill's planner), imported when the
    # first expert is built
    if attr == "MotionPlanningExpert":
        from icil_paper.sim.maniskill import expert
        return expert.MotionPlanningExpert
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def maniskill_problem() -> str | None:
    """None when ManiSkill can start here, else why not (and how to fix it)."""
    if importlib.util.find_spec("mani_skill") is None:
        return "mani_skill is not installed; install the pinned requirements with `make setup`"
    return vulkan_skip_reason() or None


MANISKILL_SUITE = Suite(
    name="maniskill", tasks=tuple(MANISKILL_TASKS), obs_dims=MANISKILL_OBS_DIMS,
    control_freq=CONTROL_FREQ, make_env=make_maniskill_env, make_expert=make_maniskill_expert,
    object_position=(0, 3), unavailable=maniskill_problem,
    description="PickCube, PushCube and StackCube of ManiSkill 3 (Panda, SAPIEN)")


__all__ = ["MANISKILL_SUITE", "MANISKILL_TASKS", "ManiSkillEnv", "make_maniskill_env",
           "make_maniskill_expert", "maniskill_problem"]
