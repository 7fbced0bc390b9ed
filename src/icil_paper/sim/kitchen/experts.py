"""Scripted experts of the kitchen suite: closed-loop state machines for doors and drawers.

The expert reads only the observation and the fixture's fixed geometry. Phases: `approach`
above the gap behind the handle bar, `descend` into it, `drag` the handle along the joint's
path until past the goal, `lift` and `retreat`. A broken precondition or an exhausted step
budget lifts the hand and starts over.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from icil_paper.sim.kitchen.scenes import COUNTER_Z, quat_xyzw_to_yaw, rot_z
from icil_paper.sim.kitchen.tasks import ALL_TASKS

POS_SCALE = 0.05
"""Metres of end-effector goal offset per unit of position action (robosuite OSC_POSE)."""
ROT_SCALE = 0.5
"""Radians of end-effector goal rotation per unit of rotation action (robosuite OSC_POSE)."""
LEAD = 2.0
"""Velocity lead of the pose servo, in control steps."""
CLOSE = 1.0
"""The gripper action that closes the hand (-1 opens it); the expert keeps it closed."""
_DOWN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""Grip-site orientation pointing down, unturned (its x axis, the closing axis, along world y)."""


def _wrap(angle: float) -> float:
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def gripper_yaw(mat: np.ndarray) -> float:
    """Yaw of a downward gripper: rotation about world z from the unturned pose."""
    return float(np.arctan2(-mat[0, 0], mat[1, 0]))


class HookExpert:
    """Doors and drawers: fingertips behind the handle bar drag the part along its path."""

    phases = ("approach", "descend", "drag", "lift", "retreat", "recover")
    budgets = {"approach": 60, "descend": 30, "drag": 120, "lift": 30}
    """Step budget per phase; running out restarts from `approach` (after lifting)."""
    safe_z = COUNTER_Z + 0.30

    def __init__(self, name: str):
        self.name = name
        self.spec = ALL_TASKS[name]
        # the Kinova arm under robosuite's OSC settles about twice as slowly as the Panda
        self.budget_scale = 2.0 if self.spec.robot == "Kinova3" else 1.0
        self._prev_eef, self.vel = None, np.zeros(3)
        self.phase = self.phases[0]
        self.t = 0
        self.restarts = 0
        # goal_q: the joint value driven towards, per goal (past the success threshold);
        # done_q: the value at which the expert lets go; step_q: how far ahead it drags
        if self.spec.scene == "door":
            self.goal_q = {"open": 1.35, "close": -0.2}
            self.done_q = {"open": 1.15, "close": 0.03}
            self.step_q = 0.22
        else:
            self.goal_q = {"open": 0.2, "close": -0.05}
            self.done_q = {"open": 0.15, "close": 0.004}
            self.step_q = 0.05

    # interface -----------------------------------------------------------------------------
    def reset(self, env, obs) -> None:
        self.env = env
        self.geometry = env.geometry
        self.phase, self.t, self.restarts = "approach", 0, 0
        self._prev_eef, self.vel = None, np.zeros(3)
        self._start(obs)

    def act(self, obs) -> np.ndarray:
        self._parse(obs)
        self.t += 1
        budget = self.budgets.get(self.phase)
        over = budget is not None and self.t > budget * self.budget_scale
        if over and self.phase not in ("retreat", "recover"):
            self._set("recover")
        if self.phase == "recover":
            action = self._recover()
        else:
            action = self._act()
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    # helpers ---------------------------------------------------------------------------------
    def _set(self, phase: str) -> None:
        if phase == "approach" and self.phase not in ("approach", ""):
            self.restarts += 1
        self.phase = phase
        self.t = 0

    def _parse(self, obs) -> None:
        p, o = obs["proprio"].astype(np.float64), obs["object"].astype(np.float64)
        self.eef = p[0:3]
        if self._prev_eef is not None:            # smoothed velocity (m per step)
            self.vel = 0.5 * self.vel + 0.5 * (self.eef - self._prev_eef)
        self._prev_eef = self.eef.copy()
        self.eef_mat = Rotation.from_quat(p[3:7]).as_matrix()
        self.yaw = gripper_yaw(self.eef_mat)
        self.q = o[0]
        self.key_pos, self.key_quat = o[1:4], o[4:8]
        self.base_pos, self.base_quat = o[8:11], o[11:15]
        self.base_yaw = quat_xyzw_to_yaw(self.base_quat)
        self.base_rot = rot_z(self.base_yaw)

    def _servo(self, target: np.ndarray, yaw: float, grip: float, speed: float = 1.0
               ) -> np.ndarray:
        """Action moving the grip site towards `target`, turned to `yaw`, pointing down."""
        action = np.zeros(7)
        # aim where the hand will be LEAD steps from now: damps overshoot of the arm's lag
        delta = (np.asarray(target) - self.eef - LEAD * self.vel) / POS_SCALE
        peak = np.max(np.abs(delta))
        action[:3] = delta * (speed / peak if peak > speed else 1.0)
        desired = rot_z(yaw) @ _DOWN
        rotvec = Rotation.from_matrix(desired @ self.eef_mat.T).as_rotvec()
        action[3:6] = np.clip(rotvec / ROT_SCALE, -1.0, 1.0)
        action[6] = grip
        return action

    def _approach(self, above: np.ndarray, yaw: float, grip: float) -> np.ndarray:
        """Servo to a point above a target, rising first when the hand is low and far away."""
        far = np.linalg.norm(above[:2] - self.eef[:2]) > 0.04
        if far and self.eef[2] < above[2] - 0.03:
            return self._servo(np.array([self.eef[0], self.eef[1], above[2]]), yaw, grip)
        return self._servo(above, yaw, grip)

    def _descend(self, target: np.ndarray, yaw: float, grip: float, speed: float = 0.6,
                 tol_xy: float = 0.008) -> np.ndarray:
        """Servo down onto `target`, holding the height while the hand is off it sideways."""
        if np.linalg.norm(target[:2] - self.eef[:2]) > tol_xy:
            target = np.array([target[0], target[1], max(target[2], self.eef[2])])
        return self._servo(target, yaw, grip, speed)

    def _near(self, target, tol_xy: float = 0.01, tol_z: float = 0.01) -> bool:
        d = np.asarray(target) - self.eef
        return bool(np.linalg.norm(d[:2]) < tol_xy and abs(d[2]) < tol_z)

    def _recover(self) -> np.ndarray:
        """Lift straight up (gripper closed), then start over."""
        target = self.eef.copy()
        target[2] = max(self.eef[2], self.safe_z)
        if self.eef[2] > self.safe_z - 0.015 or self.t > 25:
            self._set("approach")
        return self._servo(target + np.array([0, 0, 0.03]), self.yaw, CLOSE)

    def _start(self, obs) -> None:
        g = self.geometry
        self.kind, self.axis = g.joint_kind, np.asarray(g.joint_axis, dtype=float)
        self.pivot, self.hook = np.asarray(g.pivot, float), np.asarray(g.hook, float)
        self.goal = self.spec.goal
        self.safe_z = COUNTER_Z + g.top + 0.10

    def _part_rot(self, q: float) -> np.ndarray:
        return rot_z(self.axis[2] * q) if self.kind == "hinge" else np.eye(3)

    def part_point(self, q: float, local: np.ndarray) -> np.ndarray:
        """World position of `local` (moving part frame at its pivot) with the joint at q."""
        if self.kind == "hinge":
            offset = self._part_rot(q) @ local
        else:
            offset = local + q * self.axis
        return self.base_pos + self.base_rot @ (self.pivot + offset)

    def part_yaw(self, q: float) -> float:
        return self.base_yaw + (self.axis[2] * q if self.kind == "hinge" else 0.0)

    def finished(self) -> bool:
        target = self.done_q[self.goal]
        return self.q >= target if self.goal_q[self.goal] > target else self.q <= target

    def next_q(self, step: float) -> float:
        return self.q + float(np.clip(self.goal_q[self.goal] - self.q, -step, step))

    def _act(self) -> np.ndarray:
        hook = self.part_point(self.q, self.hook)
        yaw = self.part_yaw(self.q)
        if self.phase == "approach":
            above = hook + np.array([0, 0, 0.07])
            if self._near(above, 0.008, 0.02) and abs(_wrap(self.yaw - yaw)) < 0.1:
                self._set("descend")
            return self._approach(above, yaw, CLOSE)
        if self.phase == "descend":
            if np.linalg.norm(hook[:2] - self.eef[:2]) > 0.03:
                self._set("recover")
            if self._near(hook, 0.015, 0.012):
                self._set("drag")
            return self._descend(hook, yaw, CLOSE)
        if self.phase == "drag":
            if self.finished():
                self._set("lift")
            elif np.linalg.norm(hook[:2] - self.eef[:2]) > 0.05 or self.eef[2] > hook[2] + 0.03:
                self._set("recover")
            q_next = self.next_q(self.step_q)
            target = self.part_point(q_next, self.hook)
            return self._servo(target, self.part_yaw(q_next), CLOSE)
        if self.phase == "lift":
            above = np.array([self.eef[0], self.eef[1], self.safe_z])
            if self.eef[2] > hook[2] + 0.06:
                self._set("retreat")
            return self._servo(above, self.yaw, CLOSE, speed=0.6)
        # retreat: back towards the robot and up, away from the fixture
        target = np.array([self.eef[0] - 0.05, self.eef[1], self.safe_z])
        return self._servo(target, self.yaw, CLOSE, speed=0.5)
