"""Experts of the ManiSkill suite: ManiSkill's motion-planning solutions, replayed as 7-D EE deltas.

ManiSkill's solutions (`mani_skill.examples.motionplanning.panda.solutions`) plan joint-space
paths with mplib and execute them in `pd_joint_pos`. The policies of this project learn the
suite's 7-D end-effector delta actions (`env.py`'s docstring), so the expert converts:

    reset(env, obs)                                          act(obs), every step
    ---------------                                          ----------------------------------
    copy env's simulator state into a shadow env             target = plan[k + LOOKAHEAD]
      (same task, pd_joint_pos, no rendering)                a_pos  = GAIN (p_target - p_tcp) / 0.1 m
    run ManiSkill's solution there, recording after          a_rot  = GAIN log(R_target R_tcp^T) / 0.1 rad
      each step the tcp pose and gripper command  -> plan    a_grip = gripper command of plan[k]

The conversion is closed-loop (from the *current* tcp pose), and where the plan switches the
gripper the expert waits (at most `MAX_HOLD` steps) until the tcp is within `GRIP_TOLERANCE`
of where the shadow run switched it.
"""

from __future__ import annotations

import contextlib
import io
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from icil_paper.sim.maniskill.env import (
    MANISKILL_TASKS,
    POS_SCALE,
    ROT_SCALE,
    to_numpy,
    wxyz_to_xyzw,
)

GAIN = 1.0
"""Proportional gain on the pose error (1: ask for exactly the remaining delta)."""
LOOKAHEAD = 1
"""Plan steps the target runs ahead of the expert's step counter (offsets controller lag)."""
GRIP_TOLERANCE = 0.005
"""Metres the tcp may be from the planned pose when the gripper command changes."""
MAX_HOLD = 10
"""Most steps the expert waits for the tcp to reach a gripper-switch pose."""


def _to_cpu(tree: Any) -> Any:
    if isinstance(tree, dict):
        return {k: _to_cpu(v) for k, v in tree.items()}
    return tree.cpu() if hasattr(tree, "cpu") else tree


class _ShadowEnv:
    """A pd_joint_pos copy of a ManiSkill task that starts from a given simulator state."""

    def __init__(self, env_id: str):
        import gymnasium as gym
        import mani_skill.envs  # noqa: F401

        class FromState(gym.Wrapper):
            """Reset restores `state`; every step records the tcp pose and gripper command."""

            state: dict | None = None
            trace: list = []

            def reset(self, seed=None, options=None):
                # rebuilt scene: PhysX solver state from earlier plans must not leak in
                out = self.env.reset(seed=seed, options={"reconfigure": True, **(options or {})})
                if self.state is not None:
                    self.env.unwrapped.set_state_dict(self.state)
                self.trace = []
                return out

            def step(self, action):
                out = self.env.step(action)
                pose = self.env.unwrapped.agent.tcp.pose
                self.trace.append((to_numpy(pose.p).astype(np.float64),
                                   wxyz_to_xyzw(to_numpy(pose.q).astype(np.float64)),
                                   float(action[-1])))
                return out

        self.env = FromState(gym.make(env_id, obs_mode="none", control_mode="pd_joint_pos",
                                      sim_backend="physx_cpu", render_backend="cpu",
                                      max_episode_steps=10**6))

    def plan(self, solver, state: dict, seed: int) -> tuple[list, bool]:
        self.env.state = {k: _to_cpu(v) for k, v in state.items()
                          if k in ("actors", "articulations")}
        with contextlib.redirect_stdout(io.StringIO()):  # the solutions print planner status
            result = solver(self.env, seed=seed)
        solved = result != -1 and bool(to_numpy(result[-1]["success"]))
        return list(self.env.trace), solved

    def close(self) -> None:
        self.env.close()


class MotionPlanningExpert:
    """ManiSkill's motion-planning solution of a task, acting through 7-D EE delta actions;
    `planned_success` tells whether the solution succeeded in its own pd_joint_pos run."""

    def __init__(self, task: str):
        self.task = task
        self.spec = MANISKILL_TASKS[task]
        self._shadow: _ShadowEnv | None = None
        self._solver = None
        self.plan: list[tuple[np.ndarray, np.ndarray, float]] = []
        self.planned_success = False
        self._k = 0
        self._hold = 0

    def reset(self, env: Any, obs: dict[str, np.ndarray] | None = None) -> None:
        if self._shadow is None:
            from mani_skill.examples.motionplanning.panda import solutions

            self._solver = getattr(solutions, self.spec.solver)
            self._shadow = _ShadowEnv(self.spec.env_id)
        base = env.base  # the ManiSkill env inside the suite's wrapper
        seed = env.seed if env.seed is not None else 0
        self.plan, self.planned_success = self._shadow.plan(self._solver, base.get_state_dict(),
                                                            seed)
        if not self.plan:  # the solution failed before moving: hold still
            tcp = base.agent.tcp.pose
            self.plan = [(to_numpy(tcp.p).astype(np.float64),
                          wxyz_to_xyzw(to_numpy(tcp.q).astype(np.float64)), 1.0)]
        self._k = 0
        self._hold = 0

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        plan, k = self.plan, self._k
        last = len(plan) - 1
        p_tcp = obs["proprio"][:3].astype(np.float64)
        q_tcp = obs["proprio"][3:7].astype(np.float64)
        p_goal, q_goal, _ = plan[min(k + LOOKAHEAD, last)]
        grip = plan[min(k, last)][2]
        action = np.empty(7, np.float32)
        action[:3] = np.clip(GAIN * (p_goal - p_tcp) / POS_SCALE, -1.0, 1.0)
        rotvec = (Rotation.from_quat(q_goal) * Rotation.from_quat(q_tcp).inv()).as_rotvec()
        rot = GAIN * rotvec / ROT_SCALE
        norm = np.linalg.norm(rot)
        action[3:6] = rot / norm if norm > 1.0 else rot
        action[6] = -grip  # ManiSkill's +1 opens; the suite's +1 closes
        switching = k < last and plan[k + 1][2] != plan[k][2]
        if (switching and np.linalg.norm(plan[k][0] - p_tcp) > GRIP_TOLERANCE
                and self._hold < MAX_HOLD):
            self._hold += 1  # wait at the switch pose before the gripper moves
        else:
            self._k = min(k + 1, last)
            self._hold = 0
        return action

    def close(self) -> None:
        if self._shadow is not None:
            self._shadow.close()
            self._shadow = None
