"""What chapter 04 shows of each task: a rendered frame and a recorded demonstration."""

from __future__ import annotations

import io
import time
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper.data.sources import demo_seed, expert_rollout, make_source
from icil_paper.fileio import atomic_write_bytes
from icil_paper.sim import make_env, object_position, suite_of
from icil_paper.viz.recording import record_episode


def _save_png(path: Path, image: np.ndarray) -> None:
    from matplotlib.image import imsave  # no pyplot: the caller's backend stays as it is

    buf = io.BytesIO()
    imsave(buf, np.ascontiguousarray(image), format="png")
    atomic_write_bytes(path, buf.getvalue())


def showcase_task(task: str, out_dir: str | Path, base_seed: int = 0) -> dict[str, Any]:
    """Render a frame of `task` and record its `generated` demo 0; a JSON-ready dict of
    paths (`<out_dir>/<suite>__<task>.frame.png`, `.rrd`, `.png`) and figures."""
    out_dir = Path(out_dir)
    stem = task.replace("/", "__")
    options = {"render_size": 256} if suite_of(task) == "maniskill" else {}
    start = time.perf_counter()
    env = make_env(task, obs="state", seed=base_seed, **options)
    seed = demo_seed(base_seed, "generated", 0)
    try:
        env.reset(seed=seed)
        frame = env.render()
        frame_path = out_dir / f"{stem}.frame.png"
        _save_png(frame_path, frame)
        source = make_source("generated", task)
        demo, ok = expert_rollout(env, source, seed, record_states=False)
        source.close()
    finally:
        env.close()
    paths = record_episode(out_dir / f"{stem}.rrd", demo.obs, demo.actions,
                           title=f"{task}: {demo.instruction} (seed {seed})",
                           object_position=object_position(task))
    return {
        "task": task,
        "instruction": demo.instruction,
        "seed": seed,
        "success": bool(ok),
        "length": len(demo),
        "horizon": int(env.horizon),
        "frame": str(frame_path),
        "rrd": None if paths["rrd"] is None else str(paths["rrd"]),
        "picture": str(paths["png"]),
        "seconds": round(time.perf_counter() - start, 2),
    }
