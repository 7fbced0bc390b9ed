"""The one seeding function of the project, and torch's CPU thread control.

Every entry point (CLI command, notebook, test) calls `seed_everything` once with the
run's seed; nothing else in the library seeds a global generator. `cpu_threads(n)` runs a
block with n torch CPU threads (training, stand-alone tokenizer training and rollout
workers use it; a thread count changes float rounding, so it sits beside the seed).
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
    """Seed Python, NumPy and torch (if installed); return a fresh NumPy Generator.

    With `deterministic=True`, torch is asked for deterministic kernels, so that the same
    seed and preset give the same numbers on the same machine.
    """
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
