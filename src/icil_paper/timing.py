"""Where a run's time goes: wall and CPU seconds by phase, for the cost benchmark.

    from icil_paper.timing import phase, recording
    with recording() as phases:          # only while recording does `phase` measure anything
        run_cell(...)                    # the library's phases are marked with `phase(...)`
    phases.as_dict()                     # {"train.step": {"wall_s", "cpu_s", "count"}, ...}

Marked phases (`with phase("eval.sim"): env.step(a)`) do not nest, so their seconds add up
to at most the recorded wall time; outside `recording()` a `phase` costs one global lookup.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from dataclasses import dataclass, field


@dataclass
class Phases:
    """Seconds and counts by phase name."""

    wall: dict[str, float] = field(default_factory=dict)
    cpu: dict[str, float] = field(default_factory=dict)
    count: dict[str, int] = field(default_factory=dict)

    def add(self, name: str, wall_s: float, cpu_s: float) -> None:
        self.wall[name] = self.wall.get(name, 0.0) + wall_s
        self.cpu[name] = self.cpu.get(name, 0.0) + cpu_s
        self.count[name] = self.count.get(name, 0) + 1

    def as_dict(self) -> dict[str, dict[str, float]]:
        return {name: {"wall_s": round(self.wall[name], 4), "cpu_s": round(self.cpu[name], 4),
                       "count": self.count[name]} for name in sorted(self.wall)}


_ACTIVE: Phases | None = None


@contextlib.contextmanager
def phase(name: str) -> Iterator[None]:
    """Add the block's wall and CPU seconds to phase `name` while `recording()`."""
    phases = _ACTIVE
    if phases is None:
        yield
        return
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        yield
    finally:
        phases.add(name, time.perf_counter() - wall, time.process_time() - cpu)


@contextlib.contextmanager
def recording() -> Iterator[Phases]:
    """Record every `phase` of this process into a fresh `Phases` until the block ends."""
    global _ACTIVE
    previous, _ACTIVE = _ACTIVE, Phases()
    try:
        yield _ACTIVE
    finally:
        _ACTIVE = previous
