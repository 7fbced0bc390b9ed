"""Stored training runs: a RunSpec in, a `train` record and a policy file out.

    record = train_run(spec, preset.name, store)        # trains only what is missing
    policy = load_trained(spec, preset.name)             # the policy file of that run

The record's config is the run spec's keyed content (`specs.to_dict(spec, keyed_only=True)`),
so its key is `spec.key()`; it holds the training summary and the loss curve. Where a
record exists but its run folder has lost the policy file (a fresh clone holds records
only), the policy is trained again on demand by `load_trained`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from icil_paper.results import ResultsStore
from icil_paper.runspec import RunSpec, tasks_tag
from icil_paper.specs import to_dict


def train_record_name(run: RunSpec) -> str:
    """`<label>__<tasks>__<source>__seed<k>`: the results-store name of a training run."""
    return f"{run.label}__{tasks_tag(run.data.tasks)}__{run.data.source}__seed{run.seed}"


def train_run(run: RunSpec, preset: str, store: ResultsStore, run_dir: str | Path | None = None,
              force: bool = False, resume: bool = True, progress: bool = True,
              device: str | None = None, data_workers: int = 1,
              demos: Any = None) -> dict[str, Any]:
    """The `train` record of `run`, training it first if the store has none (or `force`).

    The run folder defaults to `run_dir_for(run, preset)`; training continues from its last
    checkpoint unless `resume=False` (start over).
    """
    from icil_paper.train import METRICS_FILE, policy_digest, read_metrics, run_dir_for
    from icil_paper.train.loop import finite, train_policy

    folder = Path(run_dir) if run_dir is not None else run_dir_for(run, preset)

    def compute() -> dict[str, Any]:
        result = train_policy(run, run_dir=folder, resume=resume, demos=demos, device=device,
                              progress=progress, preset=preset, data_workers=data_workers)
        lines = read_metrics(folder / METRICS_FILE)
        metrics = {k: v for k, v in result.metrics.items() if k != "device"}
        metrics.update(policy_digest=policy_digest(result.policy), run_dir=folder.name,
                       loss_steps=[x["step"] for x in lines], loss=[x["loss"] for x in lines],
                       action_l1=[x.get("action_l1") for x in lines])
        return finite(metrics)

    return store.run("train", train_record_name(run), to_dict(run, keyed_only=True), compute,
                     seed=run.seed, force=force)


def load_trained(run: RunSpec, preset: str, store: ResultsStore | None = None,
                 progress: bool = True, device: str | None = None, data_workers: int = 1):
    """The trained policy of `run`: its policy file, trained (and recorded) if missing."""
    from icil_paper.train import POLICY_FILE, load_policy, run_dir_for

    folder = run_dir_for(run, preset)
    if not (folder / POLICY_FILE).exists():
        store = store or ResultsStore(preset)
        train_run(run, preset, store, force=store.get("train", train_record_name(run),
                                                      to_dict(run, keyed_only=True)) is not None,
                  progress=progress, device=device, data_workers=data_workers)
    return load_policy(folder, map_location=device or "cpu")
