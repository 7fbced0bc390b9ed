"""The kitchen skill suite: robosuite tasks standing in for RoboCasa's seven skill families.

RoboCasa's kitchens, assets and data sets cannot be downloaded here, so the suite rebuilds its
foundational skills on a robosuite counter with fixtures generated as MJCF in code
(`fixtures.py`): a cabinet with a hinged door, a cabinet with a drawer, a faucet lever, a stove
knob, a spring button, a bin and a block with a hole. The Panda arm runs robosuite's OSC pose
controller with 7-D delta actions at 20 Hz.

    from icil_paper.sim.kitchen import make_kitchen_env, make_kitchen_expert
    env = make_kitchen_env("kitchen/open_drawer", obs="state", seed=0)
    obs, info = env.reset(seed=3)          # {"proprio": (9,), "object": (18,)} float32
    expert = make_kitchen_expert("kitchen/open_drawer"); expert.reset(env, obs)
    obs, reward, terminated, truncated, info = env.step(expert.act(obs))

Public names:

- `KITCHEN_TASKS`, `KINOVA_TASKS`: full task name -> `KitchenTaskSpec` (family, horizon,
  instruction, ...); `TASK_FAMILIES`: the paper's seven columns -> kitchen task names;
  `KITCHEN_ZERO_SHOT_SPLIT`: held-out tasks of the zero-shot table.
- `KITCHEN_OBS_DIMS = (P, O) = (9, 18)`, the widths of `proprio` and `object` for every task
  (Kinova tasks included).
- `make_kitchen_env(name, obs="state", seed=0, **options)`, `make_kitchen_expert(name)`.

The spaces are documented in `env.py`, the object-state layout in `scenes.py`, the experts'
phases in `experts.py`, the Kinova (sim-to-real stand-in) perturbations in `kinova.py`.
Importing this package does not import robosuite; building an env does.
"""

from __future__ import annotations

import os
from typing import Any

from icil_paper.registry import check_name
from icil_paper.sim.kitchen.tasks import (
    ALL_TASKS,
    FAMILIES,
    KINOVA_TASKS,
    KITCHEN_OBJECT_DIM,
    KITCHEN_PROPRIO_DIM,
    KITCHEN_TASKS,
    KITCHEN_ZERO_SHOT_SPLIT,
    TASK_FAMILIES,
    KitchenTaskSpec,
)

KITCHEN_OBS_DIMS = (KITCHEN_PROPRIO_DIM, KITCHEN_OBJECT_DIM)

# robosuite picks its OpenGL backend when it is first imported (every module of this package
# that imports it is imported through here); headless image observations need EGL.
os.environ.setdefault("MUJOCO_GL", "egl")

__all__ = ["KITCHEN_TASKS", "KINOVA_TASKS", "ALL_TASKS", "TASK_FAMILIES", "FAMILIES",
           "KITCHEN_ZERO_SHOT_SPLIT", "KITCHEN_OBS_DIMS", "KITCHEN_PROPRIO_DIM",
           "KITCHEN_OBJECT_DIM", "KitchenTaskSpec", "make_kitchen_env", "make_kitchen_expert"]


def _import_robosuite_quietly() -> None:
    """Import robosuite with its logger off, then turn the logger back on.

    On import robosuite warns about optional extras this suite does not use (a private macro
    file, robosuite_models, mink-based IK), once in every process, worker processes included.
    Only those import-time messages are hidden; later warnings are shown as usual.
    """
    import logging

    logger = logging.getLogger("robosuite_logs")
    if logger.disabled:
        return
    logger.disabled = True
    try:
        import robosuite  # noqa: F401
    finally:
        logger.disabled = False


def make_kitchen_env(name: str, obs: str = "state", seed: int = 0, **options: Any):
    """Build a kitchen or Kinova task env (`icil_paper.sim.kitchen.env.KitchenEnv`).

    Options: `camera_size` (default 84, square images), `horizon` (override the task's),
    `obs_noise_std` (override the Kinova tasks' observation noise; 0 turns it off),
    `initialization_noise` (robosuite's robot joint noise, "default" or None).
    Raises `UnknownNameError` listing the valid names for an unknown task or obs kind.
    """
    check_name("kitchen task", name, ALL_TASKS)
    check_name("observation kind", obs, ("state", "rgb", "rgbd"))
    _import_robosuite_quietly()
    from icil_paper.sim.kitchen.env import KitchenEnv

    return KitchenEnv(name, obs=obs, seed=seed, **options)


def make_kitchen_expert(name: str):
    """The scripted state-machine expert of a task: `expert.reset(env, obs)`, `expert.act(obs)`."""
    check_name("kitchen task", name, ALL_TASKS)
    from icil_paper.sim.kitchen.experts import make_kitchen_expert as make

    return make(name)
