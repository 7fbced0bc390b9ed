"""The task suites behind one registry: `TASKS`, `make_env`, `make_expert`, `obs_dims`, `suite_of`.

Three suites, named by the prefix of a task name:

- `kitchen/...`   kitchen skill tasks on robosuite (our stand-in for RoboCasa's skill families);
- `kinova/...`    the door and drawer tasks on robosuite's Kinova3 arm with perturbed dynamics
                  (our stand-in for the paper's sim-to-real transfer); same spaces as `kitchen`;
- `maniskill/...` PickCube, PushCube and StackCube of ManiSkill 3 (Table II).

Every environment is gymnasium-style::

    env = make_env("maniskill/pick_cube", obs="state", seed=0)
    obs, info = env.reset()              # obs: {"proprio": (P,), "object": (O,)} float32
    expert = make_expert("maniskill/pick_cube"); expert.reset(env, obs)
    obs, reward, terminated, truncated, info = env.step(expert.act(obs))
    info["success"]                      # the task's success predicate, a bool

with `env.name`, `env.action_dim` (7: position delta, axis-angle rotation delta, gripper, all in
[-1, 1]), `env.horizon`, `env.instruction`, `env.close()`. Image observations (`obs="rgb"` or
`"rgbd"`) add `"rgb"` (uint8, n_cams, H, W, 3) and `"depth"` (float32, n_cams, H, W). Within a
suite every task has the same `obs_dims(suite) = (P, O)`: object states are zero-padded to the
suite's width, so one policy trains on all tasks of a suite.

Suites are imported only when used, so the ManiSkill suite works while robosuite is missing and
the other way round; a suite that fails to import is named with the reason when one of its tasks
is asked for.
"""

from __future__ import annotations

import functools
import importlib
from types import ModuleType
from typing import Any

from icil_paper.registry import UnknownNameError, check_name

ACTION_DIM = 7
"""Every task's action: [dx, dy, dz, drx, dry, drz, gripper], all in [-1, 1]."""
SUITES = ("kitchen", "kinova", "maniskill")
OBJECT_POSITION = {"maniskill": (0, 3), "kitchen": (1, 4), "kinova": (1, 4)}
"""Where a suite's object state holds an object position (a slice of `obs["object"]`, for
recordings): ManiSkill's object pose starts it; the kitchen suite's key point (handle, lever
tip, knob fin, button, free object) follows the fixture's joint position
(`icil_paper.sim.kitchen.scenes`)."""
OBS_KINDS = ("state", "rgb", "rgbd")
KITCHEN_MODULE = "icil_paper.sim.kitchen"
MANISKILL_TASK_NAMES = ("maniskill/pick_cube", "maniskill/push_cube", "maniskill/stack_cube")

__all__ = ["ACTION_DIM", "TASKS", "SUITES", "OBS_KINDS", "make_env", "make_expert", "obs_dims", "suite_of",
           "tasks_of", "suite_unavailable", "SuiteUnavailable", "UnknownNameError"]


class SuiteUnavailable(ImportError):
    """A task suite whose package cannot be imported on this machine."""


@functools.lru_cache(maxsize=1)
def _kitchen() -> tuple[ModuleType | None, str | None]:
    """The kitchen package, or None and why it failed to import."""
    try:
        module = importlib.import_module(KITCHEN_MODULE)
    except Exception as exc:  # noqa: BLE001 - any failure makes the suite unavailable
        return None, f"{type(exc).__name__}: {exc}"
    missing = [a for a in ("KITCHEN_TASKS", "KITCHEN_OBS_DIMS", "make_kitchen_env",
                           "make_kitchen_expert") if not hasattr(module, a)]
    if missing:
        return None, f"{KITCHEN_MODULE} does not define {', '.join(missing)}"
    return module, None


def _kitchen_or_raise(name: str) -> ModuleType:
    module, problem = _kitchen()
    if module is None:
        raise SuiteUnavailable(f"task {name!r}: the kitchen suite ({KITCHEN_MODULE}) could not "
                               f"be imported ({problem})")
    return module


def suite_unavailable(suite: str) -> str | None:
    """None when a suite's package imports, else the reason it does not."""
    check_name("suite", suite, SUITES)
    if suite == "maniskill":
        return None  # imports lazily; a missing Vulkan device is reported by make_env
    return _kitchen()[1]


def tasks_of(suite: str) -> tuple[str, ...]:
    """The task names of one suite (empty when the suite cannot be imported)."""
    check_name("suite", suite, SUITES)
    if suite == "maniskill":
        return MANISKILL_TASK_NAMES
    module, _ = _kitchen()
    if module is None:
        return ()
    table = module.KITCHEN_TASKS if suite == "kitchen" else getattr(module, "KINOVA_TASKS", {})
    return tuple(table)


def all_tasks() -> tuple[str, ...]:
    """Every task name of every importable suite: kitchen, then kinova, then maniskill."""
    return tasks_of("kitchen") + tasks_of("kinova") + tasks_of("maniskill")


def __getattr__(attr: str) -> Any:  # PEP 562: `TASKS` is computed on first use
    if attr == "TASKS":
        return all_tasks()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def suite_of(name: str) -> str:
    """The suite a task belongs to: `kitchen`, `kinova` or `maniskill`."""
    prefix = str(name).split("/", 1)[0]
    if prefix in ("kitchen", "kinova") and _kitchen()[0] is None:
        _kitchen_or_raise(name)
    check_name("task", name, all_tasks())
    return prefix


def obs_dims(suite: str) -> tuple[int, int]:
    """(P, O): proprioception and object-state widths shared by every task of a suite."""
    check_name("suite", suite, SUITES)
    if suite == "maniskill":
        from icil_paper.sim.maniskill_suite import MANISKILL_OBS_DIMS

        return MANISKILL_OBS_DIMS
    return tuple(_kitchen_or_raise(f"{suite}/...").KITCHEN_OBS_DIMS)


def make_env(name: str, obs: str = "state", seed: int = 0, **options: Any):
    """A gymnasium-style environment of one task (see the module docstring).

    `options` go to the suite: for ManiSkill `sim_backend`, `camera_size`, `horizon`,
    `render_size`; the kitchen suite documents its own.
    """
    check_name("observation kind", obs, OBS_KINDS)
    suite = suite_of(name)
    if suite == "maniskill":
        from icil_paper.sim.maniskill_suite import make_maniskill_env

        return make_maniskill_env(name, obs=obs, seed=seed, **options)
    return _kitchen_or_raise(name).make_kitchen_env(name, obs, seed, **options)


def make_expert(name: str):
    """The scripted expert of a task: `expert.reset(env, obs)`, then `expert.act(obs)` per step."""
    suite = suite_of(name)
    if suite == "maniskill":
        from icil_paper.sim.maniskill_expert import make_maniskill_expert

        return make_maniskill_expert(name)
    return _kitchen_or_raise(name).make_kitchen_expert(name)
