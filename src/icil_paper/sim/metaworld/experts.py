"""The Meta-World suite's experts: Meta-World's scripted policies (`metaworld.policies`), one
per task, acting through the suite's 7-D action.

A scripted policy reads the raw 39-D observation and returns [dx, dy, dz, gripper], clipped
to [-1, 1] and placed at [0, 1, 2, 6] of the 7-D action.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from metaworld.policies import ENV_POLICY_MAP

from icil_paper.registry import check_name
from icil_paper.sim.metaworld.tasks import METAWORLD_TASKS
from icil_paper.sim.suite import ACTION_DIM

POLICY_CLASSES: dict[str, type] = {
    task: ENV_POLICY_MAP[spec.metaworld_id] for task, spec in METAWORLD_TASKS.items()}
"""Task name -> its scripted policy class (Meta-World's own map)."""


class MetaWorldExpert:
    """A task's scripted Meta-World policy as the suite's expert; `noise_std` adds Gaussian
    noise (action units, before clipping), seeded with the env's episode seed."""

    def __init__(self, task: str, noise_std: float = 0.0):
        check_name("Meta-World task", task, METAWORLD_TASKS)
        self.task = task
        self.policy = POLICY_CLASSES[task]()
        self.noise_std = float(noise_std)
        self.env: Any = None
        self.rng = np.random.default_rng(0)

    def reset(self, env: Any, obs: dict[str, np.ndarray] | None = None) -> None:
        """Start an episode of `env` (a reset `MetaWorldEnv`)."""
        if not hasattr(env, "raw_observation"):
            raise TypeError(f"{self.task}: the expert needs a MetaWorldEnv (with "
                            f"raw_observation()), got {type(env).__name__}")
        self.env = env
        self.rng = np.random.default_rng([int(env.seed or 0), 0x4D57])  # "MW"

    def act(self, obs: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The action (7,) float32 in [-1, 1] for the env's current state."""
        if self.env is None:
            raise RuntimeError(f"{self.task}: call expert.reset(env, obs) before act")
        move = np.asarray(self.policy.get_action(self.env.raw_observation()), np.float64)
        if self.noise_std > 0:
            move = move + self.rng.normal(0.0, self.noise_std, move.shape)
        action = np.zeros(ACTION_DIM, np.float32)
        action[[0, 1, 2, 6]] = np.clip(move, -1.0, 1.0)
        return action
