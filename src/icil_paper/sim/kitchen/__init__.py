"""The kitchen suite: door and drawer tasks on robosuite, Table V's sim-to-real stand-in.

A Panda arm opens and closes a cabinet door and a drawer (fixtures generated in code); the
Kinova tasks are the same four on a Kinova3 arm with perturbed dynamics. Table V trains on
the Panda tasks and rolls out on their Kinova twins.

Importing this package does not import robosuite; building an env does.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from typing import Any

from icil_paper.registry import check_name
from icil_paper.sim.kitchen.tasks import (
    ALL_TASKS,
    CONTROL_FREQ,
    KINOVA_TASKS,
    KITCHEN_OBJECT_DIM,
    KITCHEN_PROPRIO_DIM,
    KITCHEN_TASKS,
    SCENE_DISTRIBUTIONS,
    TASK_FAMILIES,
    KitchenTaskSpec,
)
from icil_paper.sim.suite import Suite

KITCHEN_OBS_DIMS = (KITCHEN_PROPRIO_DIM, KITCHEN_OBJECT_DIM)

# robosuite picks its OpenGL backend when it is first imported (every module of this package
# that imports it is imported through here); headless image observations need EGL.
os.environ.setdefault("MUJOCO_GL", "egl")

__all__ = ["KITCHEN_TASKS", "KINOVA_TASKS", "ALL_TASKS", "TASK_FAMILIES", "KITCHEN_OBS_DIMS",
           "KITCHEN_PROPRIO_DIM", "KITCHEN_OBJECT_DIM", "KitchenTaskSpec", "make_kitchen_env",
           "make_kitchen_expert", "KITCHEN_SUITE", "KINOVA_SUITE", "CONTROL_FREQ",
           "SCENE_DISTRIBUTIONS", "robosuite_problem"]


def _import_robosuite_quietly() -> None:
    """Import robosuite with its logger off (it warns about optional extras we do not use)."""
    logger = logging.getLogger("robosuite_logs")
    if logger.disabled:
        return
    logger.disabled = True
    try:
        import robosuite  # noqa: F401
    finally:
        logger.disabled = False


def robosuite_problem() -> str | None:
    """None when robosuite imports, else why not (the kitchen and Kinova suites need it)."""
    try:
        _import_robosuite_quietly()
    except Exception as exc:  # noqa: BLE001 - any import failure means no simulator
        return (f"robosuite cannot be imported ({type(exc).__name__}: {exc}); install the "
                "pinned requirements with `make setup`")
    return None


def make_kitchen_env(name: str, obs: str = "state", seed: int = 0, **options: Any):
    """Build a kitchen or Kinova task env (`env.KitchenEnv`).

    Options: `camera_size` (default 84), `horizon`, `obs_noise_std` (0 turns the Kinova
    noise off), `render_mode`, `scenes` (of `SCENE_DISTRIBUTIONS`, default "generated").
    """
    check_name("kitchen task", name, ALL_TASKS)  # the env checks `obs` and `scenes`
    _import_robosuite_quietly()
    return __getattr__("KitchenEnv")(name, obs=obs, seed=seed, **options)


def make_kitchen_expert(name: str):
    """The scripted state-machine expert of a task: `expert.reset(env, obs)`, `expert.act(obs)`."""
    check_name("kitchen task", name, ALL_TASKS)
    return __getattr__("HookExpert")(name)


def __getattr__(attr: str) -> Any:
    # PEP 562: the env class (robosuite, mujoco) and the experts (scipy), imported when the
    # first env or expert is built, so that listing the suite imports none of them
    if attr == "KitchenEnv":
        from icil_paper.sim.kitchen import env
        return env.KitchenEnv
    if attr == "HookExpert":
        from icil_paper.sim.kitchen import experts
        return experts.HookExpert
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


KITCHEN_SUITE = Suite(
    name="kitchen", tasks=tuple(KITCHEN_TASKS), obs_dims=KITCHEN_OBS_DIMS,
    control_freq=CONTROL_FREQ, make_env=make_kitchen_env, make_expert=make_kitchen_expert,
    object_position=(1, 4), unavailable=robosuite_problem,  # the handle's position
    scenes=SCENE_DISTRIBUTIONS, families=TASK_FAMILIES,
    description="door and drawer tasks on robosuite (Panda), Table V's training tasks")
KINOVA_SUITE = dataclasses.replace(  # the same envs and experts; one scene distribution
    KITCHEN_SUITE, name="kinova", tasks=tuple(KINOVA_TASKS), scenes=(), families=None,
    description="door and drawer tasks on a Kinova3 arm with a simulated reality gap")
