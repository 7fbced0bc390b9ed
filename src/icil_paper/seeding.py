"""The one seeding function of the project, torch's CPU thread control (a thread count
changes float rounding), and the base seeds of a preset's demonstration sets.

Every entry point calls `seed_everything` once with the run's seed; nothing else in the
library seeds a global generator.
"""

from __future__ import annotations

import contextlib
import os
import random
from collections.abc import Iterator

import numpy as np


@contextlib.contextmanager
def cpu_threads(n: int | None) -> Iterator[None]:
    """Run a block with `n` torch CPU threads (None or n <= 0: leave torch's setting alone)."""
    import torch

    before = torch.get_num_threads()
    if n is not None and n > 0:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def seed_everything(seed: int, deterministic: bool = True) -> np.random.Generator:
    """Seed Python, NumPy and torch (if installed; `deterministic`: deterministic kernels);
    return a fresh NumPy Generator."""
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    random.seed(seed)
    np.random.seed(seed % 2**32)
    os.environ["PYTHONHASHSEED"] = str(seed)
    try:
        import torch
    except ImportError:  # the library's pure-NumPy parts work without torch
        pass
    else:
        torch.manual_seed(seed)
        if deterministic:
            torch.use_deterministic_algorithms(True, warn_only=True)
            os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
            if hasattr(torch.backends, "cudnn"):
                torch.backends.cudnn.benchmark = False
    return np.random.default_rng(seed)


DATA_SET_STRIDE = 10_000
"""Seed step between the demonstration sets of a preset (`data_set_seed`)."""
DATA_SETS = 50
"""Demonstration sets a preset can have (below the `human` source's seed offset)."""


def data_set_seed(base_seed: int, index: int) -> int:
    """The base seed of demonstration set `index` (training seed k of every row trains on set
    k) of a preset whose seed is `base_seed`: base_seed + index * DATA_SET_STRIDE."""
    if not 0 <= int(index) < DATA_SETS:
        raise ValueError(f"demonstration set {index} out of range: a preset has sets 0 .. "
                         f"{DATA_SETS - 1} (one per training seed)")
    if not 0 <= int(base_seed) < DATA_SET_STRIDE:
        raise ValueError(f"base seed {base_seed} must lie in [0, {DATA_SET_STRIDE}) so that "
                         "the preset's demonstration sets do not overlap")
    return int(base_seed) + int(index) * DATA_SET_STRIDE


def data_set_index(seed: int) -> int:
    """Which demonstration set a base seed belongs to (0 for every seed below the stride)."""
    return int(seed) // DATA_SET_STRIDE
