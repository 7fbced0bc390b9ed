"""What this process has read from a data set file, kept until the file changes.

    sig = memo.signature(path)                       # None: the file is new or missing
    demos = memo.recall(sig, ("demos", limit))       # a fresh copy, or None
    memo.keep(path, sig, ("demos", limit), demos)    # kept if the file did not change

`load_demos` and `verify_file` keep what they read and hand out deep copies. A file is
known by its path, inode, size and times; one changed less than `SETTLE_S` ago is always
read afresh. At most `MAX_BYTES` of arrays are kept, the least recently used dropped first.
"""

from __future__ import annotations

import copy
import os
import time
from collections import OrderedDict
from typing import Any

import numpy as np

SETTLE_S = 2.0
"""A file changed more recently than this is not remembered (nor looked up)."""
MAX_BYTES = 1 << 30
"""Array bytes kept in all."""

_KEPT: OrderedDict[tuple, tuple[Any, int]] = OrderedDict()


def signature(path: Any) -> tuple | None:
    """What identifies the bytes of the file at `path`, or None (missing or just changed)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    if time.time() - st.st_ctime < SETTLE_S:
        return None
    return (os.path.realpath(path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns,
            st.st_ctime_ns)


def recall(sig: tuple | None, what: tuple) -> Any | None:
    """A copy of what was kept as `what` for the file of `sig`, or None."""
    if sig is None or (sig, what) not in _KEPT:
        return None
    _KEPT.move_to_end((sig, what))
    return _copy(_KEPT[sig, what][0])


def keep(path: Any, sig: tuple | None, what: tuple, value: Any) -> None:
    """Keep a copy of `value`, read from `path` as `what`, if the file still has `sig`."""
    if sig is None or signature(path) != sig:
        return
    size = _nbytes(value)
    if size > MAX_BYTES:
        return
    _KEPT[sig, what] = (_copy(value), size)
    while sum(n for _, n in _KEPT.values()) > MAX_BYTES:
        _KEPT.popitem(last=False)


def forget() -> None:
    """Drop everything kept."""
    _KEPT.clear()


def _copy(value: Any) -> Any:
    """A deep copy of arrays, dicts, lists, tuples and dataclasses (faster than deepcopy)."""
    if isinstance(value, (str, int, float, bool, type(None))):
        return value
    if isinstance(value, np.ndarray):
        return value.copy()
    if type(value) is dict:
        return {k: _copy(v) for k, v in value.items()}
    if type(value) in (list, tuple):
        return type(value)(_copy(v) for v in value)
    if hasattr(value, "__dataclass_fields__"):
        new = copy.copy(value)
        for name in value.__dataclass_fields__:
            object.__setattr__(new, name, _copy(getattr(value, name)))
        return new
    return copy.deepcopy(value)


def _nbytes(value: Any) -> int:
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, dict):
        return sum(_nbytes(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return sum(_nbytes(v) for v in value)
    if hasattr(value, "__dataclass_fields__"):
        return sum(_nbytes(getattr(value, name)) for name in value.__dataclass_fields__)
    return 0
