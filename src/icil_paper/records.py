"""The names of stored records: one `RecordId` (kind, name, config) per result a run writes.

    from icil_paper.records import eval_record, features_record, train_record
    store.get(*train_record(run))                       # the `train` record of a RunSpec
    store.run(*eval_record(run, ev), compute, seed=ev.seed)
    store.get(*features_record(run, spec))

A record's config is the keyed content of the specs it stands for, so its key is the specs'
content key (`RunSpec.key()`, `runspec.eval_key`, `runspec.feature_key`); its name is for
people reading the results folder:

| kind       | name                                                         | config              |
|------------|--------------------------------------------------------------|---------------------|
| `train`    | `<label>__<tasks>__<source>__seed<k>`                        | the RunSpec         |
| `eval`     | `<label>__<task>__<prompt source>[__prompt-<task>][__first<n>]__seed<k>` | {run, eval} |
| `features` | `<train name>__features`                                     | {run, features}     |
"""

from __future__ import annotations

from typing import Any, NamedTuple

from icil_paper.config_data import to_dict
from icil_paper.runspec import EvalSpec, FeatureSpec, RunSpec, tasks_tag


class RecordId(NamedTuple):
    """What names a stored record: `ResultsStore.get(*record_id)`, `.run(*record_id, ...)`."""

    kind: str
    """The results store's subfolder: `train`, `eval`, `features`."""
    name: str
    """The record's readable name (its file is `<name>__<key8>.json`)."""
    config: dict[str, Any]
    """The keyed content the record's key is taken over."""


def train_record_name(run: RunSpec) -> str:
    """`<label>__<tasks>__<source>__seed<k>`: the results-store name of a training run."""
    return f"{run.label}__{tasks_tag(run.data.tasks)}__{run.data.source}__seed{run.seed}"


def eval_record_name(run: RunSpec, ev: EvalSpec) -> str:
    """The results-store name of an evaluation: `<label>__<task>__<prompt source>[...]`."""
    name = f"{run.label}__{ev.task}__{ev.prompt_source}"
    if ev.prompt_task:
        name += f"__prompt-{ev.prompt_task.replace('/', '-')}"
    if ev.prompt_steps:
        name += f"__first{ev.prompt_steps}"
    return f"{name}__seed{run.seed}"


def train_record(run: RunSpec) -> RecordId:
    """The `train` record of a training run."""
    return RecordId("train", train_record_name(run), to_dict(run, keyed_only=True))


def eval_record(run: RunSpec, ev: EvalSpec) -> RecordId:
    """The `eval` record of evaluating `run`'s policy as `ev` says."""
    return RecordId("eval", eval_record_name(run, ev),
                    {"run": to_dict(run, keyed_only=True), "eval": to_dict(ev, keyed_only=True)})


def features_record(run: RunSpec, spec: FeatureSpec) -> RecordId:
    """The `features` record of measuring `run`'s tokenizer features as `spec` says."""
    return RecordId("features", f"{train_record_name(run)}__features",
                    {"run": to_dict(run, keyed_only=True),
                     "features": to_dict(spec, keyed_only=True)})
