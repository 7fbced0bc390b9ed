"""Stored evaluation records: an evaluation of a training run, computed once and kept.

    from icil_paper.eval import evaluate_run, evaluate_run_many
    record = evaluate_run(run, ev, policy, store, preset.name)      # computed if missing
    records = evaluate_run_many(run, [ev1, ev2], load, store, preset.name)

A record is named by `icil_paper.records.eval_record(run, ev)`; its key is
`runspec.eval_key(run, ev)`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

from icil_paper.eval.outcomes import evaluate_many, evaluate_policy, prompt_pool
from icil_paper.records import eval_record
from icil_paper.results import cpu_seconds
from icil_paper.runspec import EvalSpec
from icil_paper.timing import phase


def _run_prompts(run: Any, ev: EvalSpec, policy: Any, preset: Any,
                 progress: bool) -> list[Any] | None:
    if not policy.uses_prompt:
        return None
    demos = run.data.demos_for(ev.prompt_task or ev.task)
    return prompt_pool(ev, run.data.obs, demos, run.data.seed, preset, progress)


def _trained(policy: Any | Callable[[], Any]) -> Any:
    return policy if isinstance(policy, torch.nn.Module) else policy()


def evaluate_run(run: Any, ev: EvalSpec, policy: Any | Callable[[], Any], store: Any,
                 preset: Any = None, record_dir: str | Path | None = None,
                 force: bool = False, progress: bool = True,
                 batch_size: int | None = None) -> dict[str, Any]:
    """The stored evaluation of `run`'s trained policy as `ev` describes, computed if missing.

    `policy` is the policy or a function that loads it (called only when computing).
    """
    def compute() -> dict[str, Any]:
        trained = _trained(policy)
        result = evaluate_policy(trained, ev, prompts=_run_prompts(run, ev, trained, preset, progress),
                                 record_dir=record_dir, progress=progress,
                                 batch_size=batch_size)
        return result.to_dict()

    return store.run(*eval_record(run, ev), compute, seed=ev.seed, force=force)


def evaluate_run_many(run: Any, evs: Sequence[EvalSpec], policy: Any | Callable[[], Any],
                      store: Any, preset: Any = None,
                      record_dir: str | Path | None = None, force: bool = False,
                      progress: bool = True, batch_size: int | None = None,
                      keep_envs: bool = False) -> list[dict[str, Any]]:
    """`evaluate_run` for many evaluations of one run, the missing ones in one call."""
    evs = list(evs)
    ids = [eval_record(run, ev) for ev in evs]
    records = [None if force else store.get(*record_id) for record_id in ids]
    missing = [i for i, r in enumerate(records) if r is None]
    if missing:
        with phase("eval.load_policy"):
            trained = _trained(policy)
        start, cpu = time.perf_counter(), cpu_seconds()
        with phase("eval.prompts"):
            prompts = [_run_prompts(run, evs[i], trained, preset, progress) for i in missing]
        results = evaluate_many(
            trained, [evs[i] for i in missing], prompts,
            record_dir=record_dir, progress=progress, batch_size=batch_size,
            keep_envs=keep_envs)
        wall, cpu = time.perf_counter() - start, cpu_seconds() - cpu
        for i, result in zip(missing, results, strict=True):
            with phase("eval.write"):
                path = store.write(*ids[i], result.to_dict(), evs[i].seed, wall / len(missing),
                                   cpu_time_s=cpu / len(missing))
                records[i] = json.loads(Path(path).read_text())
    return records
