"""Synthetic 7-D action trajectories: a stand-in for demonstrations in tokenizer studies.

An episode is a chain of segments (reach, descend, grasp, lift, transport, release,
retreat; or a push or a drawer pull), each a minimum-jerk motion (Flash & Hogan 1985):

    s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,   tau in [0, 1]

Actions are [dx, dy, dz, drx, dry, drz, gripper] in [-1, 1], in units of POSITION_SCALE
metres and ROTATION_SCALE radians per step; `noise > 0` adds low-pass filtered noise.
"""

from __future__ import annotations

import numpy as np

from icil_paper.sim import ACTION_DIM

POSITION_SCALE = 0.02
"""Metres of end-effector motion per step for a position action of 1."""
ROTATION_SCALE = 0.05
"""Radians of rotation per step for a rotation action of 1."""
KINDS = ("pick_place", "push", "pull")


def minimum_jerk(n: int) -> np.ndarray:
    """Fraction of the motion done after each of n steps: s(k / n) for k = 1..n, shape (n,)."""
    tau = np.arange(1, n + 1) / n
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def _segment(rng: np.random.Generator, n: int, move: np.ndarray, turn: np.ndarray,
             grip_from: float, grip_to: float) -> np.ndarray:
    """n steps moving by `move` metres and turning by `turn` radians, gripper ramping."""
    s = minimum_jerk(n)
    ds = np.diff(np.concatenate([[0.0], s]))  # (n,) per-step fraction, sums to 1
    actions = np.empty((n, ACTION_DIM))
    actions[:, :3] = ds[:, None] * move / POSITION_SCALE
    actions[:, 3:6] = ds[:, None] * turn / ROTATION_SCALE
    actions[:, 6] = grip_from + (grip_to - grip_from) * s
    return actions


def _plan(rng: np.random.Generator, kind: str) -> list[tuple[int, np.ndarray, np.ndarray, float]]:
    """Segments (steps, move (3,), turn (3,), gripper at the end) of one episode."""
    u = rng.uniform
    zero = np.zeros(3)

    def turn(amount: float) -> np.ndarray:
        return np.array([u(-0.1, 0.1), u(-0.1, 0.1), u(-amount, amount)])

    reach = (int(rng.integers(20, 40)),
             np.array([u(-0.2, 0.2), u(-0.2, 0.2), u(-0.08, 0.04)]), turn(0.6), -1.0)
    descend = (int(rng.integers(8, 18)), np.array([u(-0.01, 0.01), u(-0.01, 0.01),
                                                   u(-0.12, -0.05)]), zero, -1.0)
    retreat = (int(rng.integers(8, 15)), np.array([0.0, 0.0, u(0.05, 0.1)]), zero, -1.0)
    if kind == "pick_place":
        return [
            reach, descend,
            (int(rng.integers(6, 10)), zero, zero, 1.0),  # grasp
            (int(rng.integers(10, 20)), np.array([0.0, 0.0, u(0.08, 0.18)]), zero, 1.0),  # lift
            (int(rng.integers(20, 40)), np.array([u(-0.2, 0.2), u(-0.2, 0.2), u(-0.05, 0.0)]),
             turn(0.4), 1.0),  # transport
            (int(rng.integers(6, 10)), zero, zero, -1.0),  # release
            retreat,
        ]
    if kind == "push":
        direction = rng.normal(size=2)
        direction /= np.linalg.norm(direction)
        push = np.concatenate([direction * u(0.08, 0.2), [0.0]])
        return [reach, descend, (int(rng.integers(15, 30)), push, zero, -1.0), retreat]
    if kind == "pull":
        pull = np.array([u(-0.2, -0.1), u(-0.03, 0.03), 0.0])
        return [
            reach, descend,
            (int(rng.integers(6, 10)), zero, zero, 1.0),
            (int(rng.integers(15, 30)), pull, zero, 1.0),
            (int(rng.integers(6, 10)), zero, zero, -1.0),
            retreat,
        ]
    raise ValueError(f"unknown trajectory kind {kind!r}; valid: {', '.join(KINDS)}")


def _smooth_noise(rng: np.random.Generator, n: int, scale: float, width: int = 5) -> np.ndarray:
    """Gaussian noise low-pass filtered by a moving average of `width` steps; (n, 7)."""
    raw = rng.normal(size=(n + width - 1, ACTION_DIM))
    kernel = np.ones(width) / np.sqrt(width)
    return scale * np.stack([np.convolve(raw[:, d], kernel, mode="valid")
                             for d in range(ACTION_DIM)], axis=1)


def generate_trajectory(rng: np.random.Generator, kind: str | None = None,
                        noise: float = 0.0) -> np.ndarray:
    """One episode of actions, float32 (T, 7) in [-1, 1]; T is about 60 to 150."""
    kind = kind or KINDS[int(rng.integers(len(KINDS)))]
    gripper = -1.0
    parts = []
    for steps, move, turn, grip_to in _plan(rng, kind):
        parts.append(_segment(rng, steps, move, turn, gripper, grip_to))
        gripper = grip_to
    actions = np.concatenate(parts)
    if noise > 0:
        noisy = _smooth_noise(rng, len(actions), noise)
        noisy[:, 6] = 0.0  # the gripper command stays a clean open/close signal
        actions = actions + noisy
    return np.clip(actions, -1.0, 1.0).astype(np.float32)


def generate_trajectories(n: int, seed: int = 0, noise: float = 0.0,
                          kinds: tuple[str, ...] = KINDS) -> list[np.ndarray]:
    """n episodes (float32 (T_i, 7) each), kinds drawn uniformly from `kinds`."""
    if n < 1:
        raise ValueError(f"n must be positive, got {n}")
    rng = np.random.default_rng(seed)
    return [generate_trajectory(rng, kinds[int(rng.integers(len(kinds)))], noise)
            for _ in range(n)]


def generate_actions(n_actions: int, seed: int = 0, noise: float = 0.0) -> list[np.ndarray]:
    """Whole episodes until at least `n_actions` actions in total (e.g. FAST's 1M actions)."""
    rng = np.random.default_rng(seed)
    trajectories, total = [], 0
    while total < n_actions:
        traj = generate_trajectory(rng, noise=noise)
        trajectories.append(traj)
        total += len(traj)
    return trajectories
