"""The Meta-World suite: Meta-World's 50 v3 tasks on its Sawyer arm (MuJoCo), 13 of them
standing in for the paper's seven RoboCasa skill families, with ML45 as the zero-shot split.

Importing this package imports neither metaworld nor mujoco; building an env or expert does.
"""

from __future__ import annotations

import importlib.util
import os
from typing import Any

from icil_paper.registry import check_name
from icil_paper.sim.metaworld.tasks import (
    ALL_TASK_FAMILIES,
    CONTROL_FREQ,
    FAMILIES,
    METAWORLD_TASKS,
    ML45_HELD_OUT,
    ML45_TRAIN,
    OBJECT_DIM,
    PROPRIO_DIM,
    ROBOCASA_TASKS,
    SCENE_DISTRIBUTIONS,
    TASK_FAMILIES,
    TASKS,
    ZERO_SHOT_SPLIT,
    MetaWorldTaskSpec,
    family_of,
)
from icil_paper.sim.suite import Suite

# Headless image observations need EGL; MuJoCo picks its OpenGL backend when first imported.
os.environ.setdefault("MUJOCO_GL", "egl")

__all__ = ["METAWORLD_SUITE", "METAWORLD_TASKS", "TASKS", "FAMILIES",
           "TASK_FAMILIES", "ALL_TASK_FAMILIES", "ROBOCASA_TASKS", "ML45_TRAIN", "ML45_HELD_OUT", "ZERO_SHOT_SPLIT",
           "SCENE_DISTRIBUTIONS", "CONTROL_FREQ", "MetaWorldTaskSpec", "family_of",
           "make_metaworld_env", "make_metaworld_expert", "metaworld_problem"]


def metaworld_problem() -> str | None:
    """None when Meta-World can run here, else why not (and how to fix it)."""
    for module in ("mujoco", "metaworld"):
        if importlib.util.find_spec(module) is None:
            return (f"{module} is not installed: run `make setup` (it installs "
                    "metaworld==3.1.1 --no-deps)")
    return None


def make_metaworld_env(name: str, obs: str = "state", seed: int = 0, **options: Any):
    """Build a Meta-World task env (`env.MetaWorldEnv`); options `camera_size` (default 84),
    `horizon`, `scenes` (default "generated"), `render_mode`."""
    check_name("Meta-World task", name, TASKS)  # the env checks `obs` and `scenes`
    return __getattr__("MetaWorldEnv")(name, obs=obs, seed=seed, **options)


def make_metaworld_expert(name: str, noise_std: float = 0.0):
    """The task's scripted Meta-World policy: `expert.reset(env, obs)`, `expert.act(obs)`."""
    check_name("Meta-World task", name, TASKS)
    return __getattr__("MetaWorldExpert")(name, noise_std=noise_std)


def __getattr__(attr: str) -> Any:
    # PEP 562: the env class and the experts (metaworld, mujoco), imported when the first is built
    if attr == "MetaWorldEnv":
        from icil_paper.sim.metaworld import env
        return env.MetaWorldEnv
    if attr == "MetaWorldExpert":
        from icil_paper.sim.metaworld import env
        return env.MetaWorldExpert
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


METAWORLD_SUITE = Suite(
    name="metaworld", tasks=TASKS, obs_dims=(PROPRIO_DIM, OBJECT_DIM), control_freq=CONTROL_FREQ,
    make_env=make_metaworld_env, make_expert=make_metaworld_expert,
    object_position=(0, 3), unavailable=metaworld_problem,  # the first object's position
    zero_shot_split=ZERO_SHOT_SPLIT, scenes=SCENE_DISTRIBUTIONS,
    families=ALL_TASK_FAMILIES,
    description="Meta-World (Sawyer) tasks: the paper's seven RoboCasa skill families and ML45")
