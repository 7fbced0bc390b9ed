"""What every result's table spec is built from: a row's runs, their evaluations, its entries.

    runs = seed_runs(preset, "icrt", "lipvq", preset.data.robocasa_tasks, seeds=3)
    entries = family_entries(preset, runs, preset.data.robocasa_tasks)   # a column per family + avg
    Row("icrt+lipvq", entries, paper_row)                             # one row of a TableSpec

Seed k of every row shares its demonstration set, its evaluation scenes and, for ICRT, its
backbone's initial weights and batch order (common random numbers), so rows are compared
seed by seed. Table I's runs (`table_i_runs`) are reused by the other tables.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from icil_paper.config import Preset
from icil_paper.paper_numbers import FAMILIES
from icil_paper.runspec import DataSpec, EvalSpec, RunSpec, eval_spec, run_spec
from icil_paper.seeding import data_set_seed
from icil_paper.sim import task_family
from icil_paper.sim.suite import SKILL_FAMILIES
from icil_paper.tables.spec import Entry, FeatureSpec, Row, TableSpec, Unit

FAMILY_COLUMNS = FAMILIES
"""The seven skill families (columns of Tables I, VI, VII) in the paper's order."""

ICRT_TOKENIZERS = ("mlp", "bin", "fast", "vq", "lfq", "lipvq")
"""The paper's action tokenizers in ICRT (Table I's ICRT rows, Table III's rows)."""

TOKENIZER_ROWS = tuple(f"icrt+{t}" for t in ICRT_TOKENIZERS)
"""Their row labels."""

CODEBOOK_TOKENIZERS = ("vq", "lipvq", "lfq", "fsq", "lipfsq", "rvq", "liprvq")
"""Tokenizers with a codebook: their rows carry a `features` entry for their codebook use."""


def label(policy: str, tokenizer: str | None) -> str:
    """A row's label: the policy, or `<policy>+<tokenizer>`."""
    return f"{policy}+{tokenizer}" if tokenizer else policy


def policy_tokenizer(row: str) -> tuple[str, str | None]:
    """(policy, tokenizer or None) of a row label (`definitions.label`'s inverse)."""
    policy, _, tokenizer = row.partition("+")
    return policy, tokenizer or None


def families(tasks: Sequence[str]) -> dict[str, list[str]]:
    """Paper column -> the tasks of `tasks` in that skill family (`sim.task_family`)."""
    of = {t: task_family(t) for t in tasks}
    return {column: [t for t in tasks if of[t] == family]
            for column, family in zip(FAMILY_COLUMNS, SKILL_FAMILIES, strict=True)}


def seed_runs(preset: Preset, policy: str, tokenizer, tasks: Sequence[str],
              seeds: int) -> list[RunSpec]:
    """One RunSpec per training seed (preset.seed, preset.seed + 1, ...); seed k trains on
    demonstration set k."""
    runs = [run_spec(preset, policy, tokenizer, tasks=tasks, seed=preset.seed + s)
            for s in range(seeds)]
    if policy == "mcr":  # image observations; fewer demonstrations (rendering is costly)
        suite = tasks[0].split("/", 1)[0]
        obs = "rgbd" if suite == "maniskill" else "rgb"
        runs = [run.replace(data=dataclasses.replace(
            run.data, obs=obs, demos_per_task=preset.tables.image_demos_per_task))
            for run in runs]
    return runs


def evaluation(preset: Preset, run: RunSpec, task: str, seed_index: int = 0,
               scenes: str = "generated", **prompt) -> EvalSpec:
    """The evaluation of training seed `seed_index` of a row on `task`: the preset's
    episodes; with `tables.scenes_per_seed`, seed k plays scene set k, else every seed the
    same scenes. `scenes`: the scene distribution. Prompts only for ICRT."""
    images = run.policy.type == "mcr"
    episodes = (preset.tables.image_episodes_per_task if images
                else preset.tables.episodes_for(task, preset.eval.episodes_per_task))
    max_steps = preset.tables.image_max_steps if images else None
    if run.policy.type != "icrt":
        prompt = {}  # no prompt is read: the evaluation is the same as Table I's
    seed = preset.seed + seed_index if preset.tables.scenes_per_seed else None
    return eval_spec(preset, task, episodes=episodes, seed=seed, max_steps=max_steps,
                     scenes=scenes, **prompt)


def tasks_entry(preset: Preset, runs: Sequence[RunSpec], tasks: Sequence[str],
               **prompt) -> Entry:
    """One entry over `tasks`: every seed's evaluation on each task (`evaluation`)."""
    return Entry(tuple(Unit(s, run, evaluation(preset, run, task, s, **prompt))
                      for s, run in enumerate(runs) for task in tasks))


def family_entries(preset: Preset, runs: Sequence[RunSpec], tasks: Sequence[str],
                 **prompt) -> dict[str, Entry]:
    """An entry per skill family with a task among `tasks`, and "avg" over every task."""
    entries = {column: tasks_entry(preset, runs, family_tasks, **prompt)
             for column, family_tasks in families(tasks).items() if family_tasks}
    entries["avg"] = tasks_entry(preset, runs, tasks, **prompt)
    return entries


def row_seeds(preset: Preset, table: str, row: str, default: int) -> int:
    """`tables.row_seeds`' entry for "TABLE:row", else for "TABLE:*", else `default`."""
    named = preset.tables.seeds_by_row()
    return named.get(f"{table}:{row}", named.get(f"{table}:*", default))


def table_i_seeds(preset: Preset, policy: str, tokenizer: str | None) -> int:
    """Training seeds of one Table I row (and of every table that shares its runs)."""
    default = preset.tables.icrt_seeds if policy == "icrt" else preset.tables.baseline_seeds
    return row_seeds(preset, "I", label(policy, tokenizer), default)


def table_i_runs(preset: Preset, policy: str, tokenizer) -> list[RunSpec]:
    """The runs of one Table I row (shared by Tables III, IV, V, VI and the prompt ablation)."""
    return seed_runs(preset, policy, tokenizer, preset.data.robocasa_tasks,
                     table_i_seeds(preset, policy, tokenizer))


def feature_spec(preset: Preset, run: RunSpec) -> FeatureSpec:
    """Table III's held-out trajectories: demonstrations of set 0 after the most any run
    trains on (no seed has seen them), `tables.feature_steps` features in equal shares per
    task. Every table that measures a run shares the record."""
    data = DataSpec(tasks=run.data.tasks, source="generated", obs=run.data.obs,
                    demos_per_task=preset.tables.feature_demos_per_task,
                    seed=data_set_seed(preset.seed, 0))
    return FeatureSpec(data=data, start=run.data.most_demos,
                       steps=preset.tables.feature_steps, sampling="per_task")


def features_entry(preset: Preset, runs: Sequence[RunSpec]) -> Entry:
    """One feature measurement per training seed of a row."""
    return Entry(tuple(Unit(s, run, features=feature_spec(preset, run))
                      for s, run in enumerate(runs)))


def with_codebook(preset: Preset, entries: dict[str, Entry], runs: Sequence[RunSpec]
                  ) -> dict[str, Entry]:
    """`entries`, plus a `features` entry where the runs' tokenizer has a codebook."""
    tokenizer = runs[0].tokenizer
    if tokenizer is not None and tokenizer.type in CODEBOOK_TOKENIZERS:
        entries = {**entries, "features": features_entry(preset, runs)}
    return entries


def icrt_rows(preset: Preset, seeds: dict[str, int]) -> TableSpec:
    """Table I's protocol for chosen ICRT tokenizers, {tokenizer: seeds} (`icil-paper
    compare`): Table I's runs and evaluations, so stored entries are reused."""
    tasks = preset.data.robocasa_tasks
    rows = tuple(Row(label("icrt", tok),
                     family_entries(preset, seed_runs(preset, "icrt", tok, tasks, n), tasks))
                 for tok, n in seeds.items())
    return TableSpec("I", "ICRT tokenizers on Table I's protocol (our kitchen suite)",
                     (*FAMILY_COLUMNS, "avg"), rows, note=(
                         "Table I's runs and evaluations for the chosen tokenizers; avg is "
                         "the mean over tasks."))

