"""`Suite`: what the library needs to know about a task suite, in one record.

Each suite module defines one record and `icil_paper.sim` lists it in its registry by name, so
adding a suite is one module plus one registry line::

    SUITE = Suite(
        name="mysuite", tasks=("mysuite/reach", ...), obs_dims=(9, 12), control_freq=20,
        make_env=make_my_env,          # (name, obs="state", seed=0, **options) -> TaskEnv
        make_expert=make_my_expert,    # (name) -> expert with reset(env, obs), act(obs)
        object_position=(0, 3),        # obs["object"][0:3] is an object's position
        unavailable=my_problem,        # () -> None, or why the simulator cannot run here
    )
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from icil_paper.benchmark_tasks import SKILL_FAMILIES  # noqa: F401 - the suites read it here

ACTION_DIM = 7
"""Every task's action: [dx, dy, dz, drx, dry, drz, gripper], all in [-1, 1]."""
OBS_KINDS = ("state", "rgb", "rgbd")


def always_available() -> str | None:
    """The availability check of a suite that needs nothing beyond the library itself."""
    return None


@dataclass(frozen=True)
class Suite:
    """One task suite: its tasks, observation widths, env and expert factories."""

    name: str
    """Prefix of the suite's task names (`<name>/<task>`)."""
    tasks: tuple[str, ...]
    """Every task name of the suite, in display order."""
    obs_dims: tuple[int, int]
    """(P, O): widths of `obs["proprio"]` and `obs["object"]`, shared by every task."""
    control_freq: int
    """Control rate in Hz (env steps per simulated second); the envs' `render_fps`."""
    make_env: Callable[..., Any]
    """`(name, obs="state", seed=0, **options) -> env`, a `icil_paper.sim.base.TaskEnv`."""
    make_expert: Callable[[str], Any]
    """`(name) -> expert`: `expert.reset(env, obs)`, then `expert.act(obs)` every step."""
    object_position: tuple[int, int] | None = None
    """(start, stop): the slice of `obs["object"]` holding an object's position, or None."""
    unavailable: Callable[[], str | None] = always_available
    """None when the suite's simulator can run on this machine, else why not."""
    zero_shot_split: Mapping[str, Sequence[str]] | None = None
    """Tasks trained on and held out in the zero-shot setting ({"train": ..., "test": ...})."""
    scenes: tuple[str, ...] = ()
    """Named scene distributions `make_env`'s `scenes` option selects, the default first."""
    families: Mapping[str, Sequence[str]] | None = None
    """The paper's skill families (`SKILL_FAMILIES`) -> this suite's tasks of that family."""
    description: str = ""
    """One line on what the suite is."""

    def family_of(self, task: str) -> str | None:
        """The skill family of one of the suite's tasks, or None."""
        return next((family for family, tasks in (self.families or {}).items()
                     if task in tasks), None)
