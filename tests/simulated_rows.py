"""The model of a row's outcomes that the calibration tests simulate, at the spreads
measured in the reference run: per-task success rates of the kitchen suite, a training
seed's shift of its whole row, and a scene's shift of one episode."""

from __future__ import annotations

import numpy as np

TASK_RATES = np.array([0.0, 0.0, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7, 0.9, 1.0, 1.0])
"""Success rates of the 11 kitchen tasks (floors and ceilings included)."""
SEED_SPREAD = 0.05
"""Standard deviation of a training seed's shift of every task's success rate."""
SCENE_SPREAD = 0.2
"""Standard deviation of a scene's shift of one episode's success probability."""
