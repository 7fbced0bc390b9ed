"""Stored training runs: a RunSpec in, a `train` record and a policy file out (the stored-run
layer of `train/`, as `eval/stored.py` is of evaluation).

    record = train_run(spec, preset.name, store)        # trains only what is missing
    policy = load_trained(spec, preset.name)             # the policy file of that run

The record is named by `icil_paper.records.train_record(spec)`: its config is the run
spec's keyed content, so its key is `spec.key()`; it holds the training summary and the loss curve, and names the
SHA-256 of the policy file it stands for (`files`). A stored record is reported only with
its file: where the run folder's `policy.pt` is missing (a fresh clone holds records only)
or is not the file the record was written with, the record is stale, the changed file is
set aside (kept, never deleted) and the run is computed again, resuming from its
checkpoints (bit for bit the same policy on CPU). A record written before records named
their files is verified by loading its policy file and comparing the weights' digest with
the record's `policy_digest`.

Evaluation trusts a policy file only with its record (`trusted_policy`): its own key must be
the run's and the run's record must name it; otherwise it is set aside and the run computed
again, so an evaluation is never stored under another run's key.

The run folder's lock (`train.rundir.run_lock`) is held from that check to the new record,
so two processes asking for one run train it once: the second waits, then finds the record
and its file as the first one left them.
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
    """Why `record` does not stand for the policy file in `folder`, or None when it does
    (by its `files` digest, or for an older record without one, by loading the file)."""
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
    """The `train` record of `run`, training it first if the store has none (or `force`),
    or if the run folder's policy file is not the one the record names (module docstring).

    `preset` is the Preset whose data folder (`data.root`) holds the data sets, or its
    name. The run folder defaults to `run_dir_for(run, <its name>)`; training continues from
    its last checkpoint unless `resume=False` (start over).
    """
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
    """Why the policy file at `path` is not `run`'s by its own record of the run it was
    trained for (the key in its meta), or None when it is. A damaged file raises
    PolicyFileError (one line naming it)."""
    key = getattr(load_policy(path), "meta", {}).get("key")
    if key != run.key():
        return (f"{path.name} was trained for the run of key {key}, not this run's "
                f"{run.key()}")
    return None


def trusted_policy(run: RunSpec, preset: Any, store: ResultsStore, run_dir: str | Path,
                   progress: bool = True, device: str | None = None, data_workers: int = 1):
    """The policy file in `run_dir`, loaded only once it is known to be `run`'s: its own key
    is `run.key()` and the stored `train` record of `run` names its SHA-256 (`train_run`).

    A policy file of another run, or one that its record does not name, is set aside (kept,
    with a warning) and the run is computed again from its checkpoints, so an evaluation is
    never stored under the key of a run whose policy it did not roll out. In a run folder
    this process cannot write to, nothing can be set aside: such a file is a PolicyFileError
    naming it instead, as is a damaged file anywhere.
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
    """The trained policy of `run`: its policy file, as its `train` record names it (trained,
    or trained again, and recorded where it is missing or stale: `train_run`)."""
    folder = run_dir_for(run, preset_name(preset))
    with run_lock(folder):  # the file checked is the file loaded
        train_run(run, preset, store or ResultsStore(preset_name(preset)), progress=progress,
                  device=device, data_workers=data_workers)
        return load_policy(folder, map_location=device or "cpu")
