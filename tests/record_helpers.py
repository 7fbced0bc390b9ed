"""Writing fake evaluation records for table tests: one helper for every test file."""

from __future__ import annotations

from icil_paper.config_data import to_dict
from icil_paper.records import eval_record_name


def write_eval_record(store, unit, per_episode: list[dict], mean_steps: float) -> None:
    """Store `per_episode` as the eval record of `unit` (a table cell's unit), as
    `evaluate` would write it (intervals and wall times are placeholders)."""
    n = len(per_episode)
    successes = sum(e["success"] for e in per_episode)
    store.write("eval", eval_record_name(unit.run, unit.eval),
                {"run": to_dict(unit.run, keyed_only=True),
                 "eval": to_dict(unit.eval, keyed_only=True)},
                {"task": unit.eval.task, "episodes": n, "successes": successes,
                 "success_rate": successes / n, "ci_low": 0.0, "ci_high": 1.0,
                 "mean_steps": mean_steps, "wall_time_s": 0.0, "per_episode": per_episode},
                seed=unit.run.seed, wall_time_s=0.0)
