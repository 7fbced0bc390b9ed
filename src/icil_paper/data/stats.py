"""Statistics of demonstration data sets: lengths, keep rates, and how smooth the actions are.

Smoothness is the least energy (Table III's measure) of the 6 motion dims per second
difference: the mean squared acceleration of the commanded motion, lower is smoother.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from icil_paper.data.hdf5 import Demo
from icil_paper.metrics import least_energy

STILL_RELATIVE = 0.1
"""A step stands still when its motion norm is below this fraction of the demo's 90th
percentile."""


def action_least_energy_per_step(actions: np.ndarray) -> float:
    """least_energy of the motion dims (T, 6) divided by its T - 2 second differences."""
    motion = np.asarray(actions, dtype=np.float64)[:, :6]
    if motion.shape[0] < 3:
        return 0.0
    return least_energy(motion) / (motion.shape[0] - 2)


def demo_stats(demo: Demo) -> dict[str, Any]:
    """One row of statistics of a demo."""
    motion = np.abs(demo.actions[:, :6])
    norms = np.linalg.norm(demo.actions[:, :6], axis=1)
    still = norms < STILL_RELATIVE * np.percentile(norms, 90) if len(norms) else norms > 0
    attempt = demo.meta.get("attempt")
    return {
        "task": demo.task,
        "source": demo.source,
        "seed": demo.seed,
        "length": len(demo),
        "least_energy_per_step": action_least_energy_per_step(demo.actions),
        "mean_abs_motion": float(motion.mean()),
        "still_fraction": float(np.mean(still)) if len(norms) else 0.0,
        "gripper_switches": int(np.sum(np.diff(np.sign(demo.actions[:, 6])) != 0)),
        "attempts": None if attempt is None else int(attempt) + 1,
    }


def data_set_stats(demos: Sequence[Demo]) -> list[dict[str, Any]]:
    """Rows of `demo_stats` for every demo (a pandas DataFrame takes them as they are)."""
    return [demo_stats(d) for d in demos]


def keep_rate(demos: Sequence[Demo]) -> float | None:
    """Share of episodes that succeeded and became demos (None without attempt records)."""
    attempts = [d.meta.get("attempt") for d in demos]
    if not attempts or any(a is None for a in attempts):
        return None
    return len(demos) / float(sum(int(a) + 1 for a in attempts))
