"""Splits: train/valid demos within a file, and the task splits of the generalization tables."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from icil_paper.sim import get_suite, tasks_of


def train_valid_split(names: Sequence[str], valid_fraction: float = 0.1,
                      seed: int = 0) -> dict[str, list[str]]:
    """Split demo names into `train` and `valid` (round(fraction * n) valid demos, seeded)."""
    if not 0.0 <= valid_fraction < 1.0:
        raise ValueError(f"valid_fraction must be in [0, 1), got {valid_fraction}")
    names = list(names)
    n_valid = int(round(valid_fraction * len(names)))
    order = np.random.default_rng(seed).permutation(len(names))
    valid = set(order[:n_valid].tolist())
    return {"train": [n for i, n in enumerate(names) if i not in valid],
            "valid": [n for i, n in enumerate(names) if i in valid]}


_TRAIN_KEYS = ("train", "seen", "training")
_HELD_OUT_KEYS = ("held_out", "heldout", "test", "eval", "unseen", "zero_shot")


def _normalize_split(split) -> tuple[tuple[str, ...], tuple[str, ...]]:
    if isinstance(split, Mapping):
        train = next((split[k] for k in _TRAIN_KEYS if k in split), None)
        held = next((split[k] for k in _HELD_OUT_KEYS if k in split), None)
        if train is None or held is None:
            raise ValueError(f"cannot read a zero-shot split with keys {sorted(split)}")
        return tuple(train), tuple(held)
    if hasattr(split, "train") and hasattr(split, "held_out"):
        return tuple(split.train), tuple(split.held_out)
    train, held = split
    return tuple(train), tuple(held)


def zero_shot_split(suite: str = "metaworld") -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(training tasks, held-out tasks) of a suite's zero-shot setting (Table VII)."""
    split = get_suite(suite, f"the {suite} zero-shot split").zero_shot_split
    if split is None:
        raise ValueError(f"the {suite} suite defines no zero-shot split")
    train, held = _normalize_split(split)
    overlap = set(train) & set(held)
    if overlap:
        raise ValueError(f"zero-shot split trains on held-out tasks {sorted(overlap)}")
    return train, held


def sim_to_real_pairs() -> dict[str, str]:
    """{kinova task: the kitchen (Panda) task of the same skill} for every Kinova task."""
    kitchen = set(tasks_of("kitchen"))
    pairs = {}
    for task in tasks_of("kinova"):
        twin = "kitchen/" + task.split("/", 1)[1]
        if twin in kitchen:
            pairs[task] = twin
    return pairs
