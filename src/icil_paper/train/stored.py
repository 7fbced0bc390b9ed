"""Stored training runs: a RunSpec in, a `train` record and a policy file out.

    record = train_run(spec, preset.name, store)        # trains only what is missing
    policy = load_trained(spec, preset.name)             # the policy file of that run

The record (key `spec.key()`) holds the training summary, the loss curve and the SHA-256
of the policy file it stands for. Where that file is missing or another one, the record is
stale: the file is set aside and the run computed again from its checkpoints.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any

from icil_paper.records import train_record
from icil_paper.results import ResultsStore, files_problem
from icil_paper.runspec import RunSpec
from icil_paper.train.loop import finite, train_policy
from icil_paper.train.rundir import (
    METRICS_FILE,
    POLICY_FILE,
    PolicyFileError,
    load_policy,
    policy_digest,
    read_metrics,
    run_dir_for,
    run_lock,
    set_aside_damaged,
)


class StaleRecordWarning(UserWarning):
    """A stored record whose files are not the ones it was written with; it is recomputed."""


def _policy_problem(record: dict[str, Any], folder: Path) -> str | None:
    """Why `record` does not stand for the policy file in `folder`, or None when it does."""
    path = folder / POLICY_FILE
    if not path.exists():
        return f"{POLICY_FILE} is missing"
    if record.get("files"):
        return files_problem(record, folder)
    try:
        loaded = load_policy(path)
    except ValueError:  # PolicyFileError: damaged, foreign, or weights off its spec
        return f"{POLICY_FILE} cannot be read as a policy"
    if policy_digest(loaded) != record["metrics"].get("policy_digest"):
        return f"{POLICY_FILE} holds other weights than the record's"
    return None


def preset_name(preset: Any) -> str:
    """The name of a Preset, or the name itself."""
    return preset if isinstance(preset, str) else preset.name


def train_run(run: RunSpec, preset: Any, store: ResultsStore, run_dir: str | Path | None = None,
              force: bool = False, resume: bool = True, progress: bool = True,
              device: str | None = None, data_workers: int = 1,
              demos: Any = None) -> dict[str, Any]:
    """The `train` record of `run`, training it first where the store has none (or `force`)
    or the run folder's policy file is not the one the record names."""
    folder = Path(run_dir) if run_dir is not None else run_dir_for(run, preset_name(preset))
    record_id = train_record(run)

    def compute() -> dict[str, Any]:
        result = train_policy(run, run_dir=folder, resume=resume, demos=demos, device=device,
                              progress=progress, preset=preset, data_workers=data_workers)
        lines = read_metrics(folder / METRICS_FILE)
        metrics = {k: v for k, v in result.metrics.items() if k != "device"}
        metrics.update(policy_digest=policy_digest(result.policy), run_dir=folder.name,
                       loss_steps=[x["step"] for x in lines], loss=[x["loss"] for x in lines],
                       action_l1=[x.get("action_l1") for x in lines])
        return finite(metrics)

    with run_lock(folder):
        record = None if force else store.get(*record_id)
        if record is not None:
            problem = _policy_problem(record, folder)
            if problem is None:
                return record
            if (folder / POLICY_FILE).exists():
                set_aside_damaged(folder / POLICY_FILE, "not the file its train record names")
            warnings.warn(f"the stored train record {record_id.name} is stale: in {folder}, {problem}; "
                          "computing it again (from the run's checkpoints where they are "
                          "whole)", StaleRecordWarning, stacklevel=2)
        return store.run(*record_id, compute, seed=run.seed, force=True,
                         files=lambda: {POLICY_FILE: folder / POLICY_FILE})


def policy_key_problem(path: Path, run: RunSpec) -> str | None:
    """Why the policy file at `path` is not `run`'s by the key in its meta, or None."""
    key = getattr(load_policy(path), "meta", {}).get("key")
    if key != run.key():
        return (f"{path.name} was trained for the run of key {key}, not this run's "
                f"{run.key()}")
    return None


def trusted_policy(run: RunSpec, preset: Any, store: ResultsStore, run_dir: str | Path,
                   progress: bool = True, device: str | None = None, data_workers: int = 1):
    """The policy file in `run_dir`, loaded only once its key is `run.key()` and `run`'s
    `train` record names it; otherwise it is set aside and the run computed again (in a
    folder this process cannot write to: PolicyFileError).
    """
    folder = Path(run_dir)
    if folder.is_dir() and not os.access(folder, os.W_OK):  # read-only: check, never write
        path = folder / POLICY_FILE
        record = store.get(*train_record(run))
        problem = policy_key_problem(path, run) or (
            f"the results store has no train record of run {run.key()}" if record is None
            else _policy_problem(record, folder))
        if problem is not None:
            raise PolicyFileError(f"{path} is not this run's trained policy ({problem}); "
                                  "train the run again where its folder can be written "
                                  "(icil-paper train), or restore the file")
        return load_policy(folder, map_location=device or "cpu")
    with run_lock(folder):  # the file checked is the file loaded
        path = folder / POLICY_FILE
        if path.exists():
            problem = policy_key_problem(path, run)
            if problem is not None:
                set_aside_damaged(path, problem)
        train_run(run, preset, store, run_dir=folder, progress=progress, device=device,
                  data_workers=data_workers)
        return load_policy(folder, map_location=device or "cpu")


def load_trained(run: RunSpec, preset: Any, store: ResultsStore | None = None,
                 progress: bool = True, device: str | None = None, data_workers: int = 1):
    """The trained policy of `run`, trained and recorded where missing or stale (`train_run`)."""
    folder = run_dir_for(run, preset_name(preset))
    with run_lock(folder):  # the file checked is the file loaded
        train_run(run, preset, store or ResultsStore(preset_name(preset)), progress=progress,
                  device=device, data_workers=data_workers)
        return load_policy(folder, map_location=device or "cpu")
