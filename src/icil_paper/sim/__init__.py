"""The task suites behind one registry: `TASKS`, `make_env`, `make_expert`, `obs_dims`, `suite_of`.

    env = make_env("maniskill/pick_cube", obs="state", seed=0)   # a gymnasium.Env (TaskEnv)
    obs, info = env.reset()              # obs: {"proprio": (P,), "object": (O,)} float32
    expert = make_expert("maniskill/pick_cube"); expert.reset(env, obs)
    obs, reward, terminated, truncated, info = env.step(expert.act(obs))
    info["success"]                      # the task's success predicate, a bool

Suites, named by the prefix of a task name: `metaworld/`, `kitchen/` (robosuite's Panda),
`kinova/` (the sim-to-real stand-in), `maniskill/` (Table II) and `synthetic/` (tests).
Actions are 7-D in [-1, 1]; every task of a suite has the same `obs_dims(suite) = (P, O)`.
Image observations (`obs="rgb"` or `"rgbd"`) add `rgb` (uint8, n_cams, H, W, 3) and `depth`
(float32 metres). Suite modules are imported only when used; importing this package
registers a gymnasium id per task (`gym_id`).
"""

from __future__ import annotations

import functools
from typing import Any

from icil_paper.registry import UnknownNameError, check_name
from icil_paper.sim.suite import ACTION_DIM, OBS_KINDS

SUITES = ("metaworld", "kitchen", "kinova", "maniskill")
"""The simulated suites of the paper's tables, in display order."""
GYM_NAMESPACE = "icil_paper"

__all__ = ["ACTION_DIM", "ALL_SUITES", "OBS_KINDS", "SUITES", "SUITE_REGISTRY", "TASKS",
           "SuiteUnavailable", "UnknownNameError", "all_tasks", "get_suite", "gym_id",
           "make_env", "make_expert", "object_position", "obs_dims", "register_gym_envs",
           "scene_distributions", "suite_of", "suite_unavailable", "task_family", "tasks_of"]


class SuiteUnavailable(ImportError):
    """A task suite whose module cannot be loaded on this machine."""


def _load(suite: str) -> tuple[Any, str | None]:
    """The suite's record, or None and why it failed to load."""
    check_name("suite", suite, SUITE_REGISTRY)
    try:
        return SUITE_REGISTRY[suite](), None
    except Exception as exc:  # noqa: BLE001 - any failure makes the suite unavailable
        return None, f"{type(exc).__name__}: {exc}"


def get_suite(suite: str, context: str | None = None):
    """The `Suite` record of a suite; SuiteUnavailable (naming `context`) if it cannot load."""
    record, problem = _load(suite)
    if record is None:
        where = f"{context}: " if context else ""
        raise SuiteUnavailable(f"{where}the {suite} suite could not be loaded ({problem})")
    return record


def suite_unavailable(suite: str) -> str | None:
    """None when a suite's module loads and its simulator can run here, else the reason."""
    record, problem = _load(suite)
    return problem if record is None else record.unavailable()


def tasks_of(suite: str) -> tuple[str, ...]:
    """The task names of one suite (empty when the suite cannot be loaded)."""
    record, _ = _load(suite)
    return () if record is None else tuple(record.tasks)


def all_tasks() -> tuple[str, ...]:
    """Every task name of every loadable suite of `SUITES`, in their order."""
    return tuple(task for suite in SUITES for task in tasks_of(suite))


def __getattr__(attr: str) -> Any:  # PEP 562: `TASKS` and each suite's record on first use
    if attr == "TASKS":
        return all_tasks()
    if attr == "METAWORLD_SUITE":
        from icil_paper.sim import metaworld
        return metaworld.METAWORLD_SUITE
    if attr in ("KITCHEN_SUITE", "KINOVA_SUITE"):
        from icil_paper.sim import kitchen
        return getattr(kitchen, attr)
    if attr == "MANISKILL_SUITE":
        from icil_paper.sim import maniskill
        return maniskill.MANISKILL_SUITE
    if attr == "SYNTHETIC_SUITE":
        from icil_paper.sim import synthetic
        return synthetic.SYNTHETIC_SUITE
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


SUITE_REGISTRY = {suite: functools.partial(__getattr__, f"{suite.upper()}_SUITE")
                  for suite in ("metaworld", "kitchen", "kinova", "maniskill", "synthetic")}
"""Suite name -> a function returning its `Suite` record (its module imported on first use)."""
ALL_SUITES = tuple(SUITE_REGISTRY)


def suite_of(name: str) -> str:
    """The suite a task belongs to (`kitchen`, `kinova`, `maniskill` or `synthetic`)."""
    prefix = str(name).split("/", 1)[0]
    if prefix not in SUITE_REGISTRY:
        check_name("task", name, all_tasks())  # raises, listing the valid names
    check_name("task", name, get_suite(prefix, f"task {name!r}").tasks)
    return prefix


def task_family(task: str) -> str | None:
    """The paper's skill family (`SKILL_FAMILIES`) that `task` stands in for, or None."""
    prefix = str(task).split("/", 1)[0]
    record, _ = _load(prefix) if prefix in SUITE_REGISTRY else (None, None)
    return None if record is None else record.family_of(task)


def obs_dims(suite: str) -> tuple[int, int]:
    """(P, O): proprioception and object-state widths shared by every task of a suite."""
    return tuple(get_suite(suite).obs_dims)


def object_position(task: str) -> tuple[int, int] | None:
    """The slice (start, stop) of `obs["object"]` holding an object's position, or None."""
    prefix = str(task).split("/", 1)[0]
    if prefix not in SUITE_REGISTRY:
        return None
    record, _ = _load(prefix)
    return None if record is None else record.object_position


def make_env(name: str, obs: str = "state", seed: int = 0, **options: Any):
    """A `gymnasium.Env` of one task; `options` go to the suite's `make_env`."""
    check_name("observation kind", obs, OBS_KINDS)
    suite = suite_of(name)
    return get_suite(suite).make_env(name, obs=obs, seed=seed, **options)


def scene_distributions(name: str) -> tuple[str, ...]:
    """The scene distributions `make_env(..., scenes=)` offers for a task, the default first."""
    return tuple(get_suite(suite_of(name)).scenes)


def make_expert(name: str):
    """The scripted expert of a task: `expert.reset(env, obs)`, then `expert.act(obs)` per step."""
    return get_suite(suite_of(name)).make_expert(name)


def gym_id(task: str) -> str:
    """The gymnasium id of a task: `kitchen/open_drawer` -> `icil_paper/kitchen-open_drawer-v0`."""
    return f"{GYM_NAMESPACE}/{task.replace('/', '-')}-v0"


def register_gym_envs() -> list[str]:
    """Register a gymnasium id for every task of every loadable suite (once); return the ids."""
    import gymnasium

    ids = []
    for suite in ALL_SUITES:
        for task in tasks_of(suite):
            env_id = gym_id(task)
            if env_id not in gymnasium.registry:
                gymnasium.register(env_id, entry_point="icil_paper.sim:make_env",
                                   kwargs={"name": task})
            ids.append(env_id)
    return ids


try:
    register_gym_envs()
except ImportError:  # gymnasium missing: the envs cannot be built either; make_env says why
    pass
