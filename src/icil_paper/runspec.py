"""Run specs: everything a training run or an evaluation reads, with one content key each.

    spec = run_spec(preset, policy="icrt", tokenizer="lipvq", tasks=["kitchen/open_drawer"])
    spec.key()                       # 16 hex digits over every field that shapes the policy
    ev = eval_spec(preset, "kitchen/open_drawer", episodes=10)
    eval_key(spec, ev)               # the key of that policy's evaluation
    feature_key(spec, FeatureSpec(...))  # of a measurement of its tokenizer's features (Table III)

A `RunSpec` is the data, the policy's and tokenizer's configs, the training loop and the
training seed. Run folders, stored records and table cells take their keys from these specs
alone, so a changed knob never returns a stale result.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from icil_paper.config import DEMO_SOURCES, OBS_KINDS, Preset, TrainConfig, task_demo_counts
from icil_paper.config_data import (
    KEYED_WHEN_SET,
    Checked,
    ConfigError,
    from_dict,
    spec_key,
)
from icil_paper.policies.configs import PolicyConfig, resolve_tokenizer
from icil_paper.seeding import data_set_seed
from icil_paper.tokenizers.configs import TokenizerConfig

SCENE_DISTRIBUTIONS = ("generated", "human")
"""Scene distributions an evaluation can name; the first is every suite's default."""


SUITE_VERSION = 4
"""The version of the task suites' scenes, success checks and experts, in every data and
evaluation key; raise it whenever one of them changes."""


@dataclass(frozen=True)
class DataSpec(Checked):
    """The demonstrations a policy is trained on."""

    CHOICES = {"obs": OBS_KINDS, "source": (*DEMO_SOURCES, "file")}

    tasks: tuple[str, ...]
    """Task names (`icil_paper.sim`); one policy is trained on all of them."""
    source: str = "generated"
    """Demonstration source: `generated` (the MimicGen stand-in) or `human`."""
    obs: str = "state"
    """Observations learned from: `state`, `rgb` or `rgbd`."""
    demos_per_task: int = 10
    """Demonstrations per task (the first ones of each data set)."""
    task_demos: tuple[str, ...] = field(default=(), metadata=KEYED_WHEN_SET)
    """Exceptions to `demos_per_task` for some of `tasks`, each `TASK:N`."""
    seed: int = 0
    """Base seed the demonstrations are generated from."""
    dataset: str | None = None
    """A robomimic-layout HDF5 file to train on instead of generated data sets."""
    dataset_sha256: str | None = None
    """The SHA-256 of `dataset` (so that a changed file is a different run)."""
    obs_keys: tuple[str, ...] | None = None
    """`dataset` only: the observation keys read from it (None: the documented default)."""
    suite_version: int = SUITE_VERSION
    """The task suites' version the demonstrations were made on (`SUITE_VERSION`)."""

    def __post_init__(self) -> None:
        super().__post_init__()  # a task list, a source, an observation kind: before any work
        task_demo_counts(self.task_demos)

    def demos_for(self, task: str) -> int:
        """Demonstrations of `task` trained on."""
        return task_demo_counts(self.task_demos).get(task, self.demos_per_task)

    @property
    def most_demos(self) -> int:
        """The most demonstrations trained on of any task (held-out ones start after them)."""
        return max(self.demos_for(t) for t in self.tasks)


@dataclass(frozen=True)
class RunSpec(Checked):
    """One training run: what it learns from, what it trains and how."""

    data: DataSpec
    """The demonstrations."""
    policy: PolicyConfig
    """The policy's config (its `type` names the policy)."""
    tokenizer: TokenizerConfig | None
    """The action tokenizer's config, or None for a policy without one."""
    train: TrainConfig
    """The training loop."""
    seed: int = 0
    """Training seed (`seed_everything`)."""

    @property
    def label(self) -> str:
        """`icrt+lipvq`, `act`, `bc_transformer`, ..."""
        tok = self.tokenizer.type if self.tokenizer is not None else None
        return f"{self.policy.type}+{tok}" if tok else self.policy.type

    def key(self) -> str:
        """The content key of this run (see the module docstring)."""
        return spec_key(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunSpec:
        return from_dict(cls, data)

    def replace(self, **changes: Any) -> RunSpec:
        return dataclasses.replace(self, **changes)


EVAL_RECORD_VERSION = 2
"""What an evaluation record holds (2: success, steps, return and motion smoothness), in
every evaluation's key; raise it whenever a record gains a measurement."""


@dataclass(frozen=True)
class EvalSpec(Checked):
    """Rollouts of one trained policy on one task."""

    CHOICES = {"prompt_source": DEMO_SOURCES, "scenes": SCENE_DISTRIBUTIONS}

    task: str
    """The task rolled out."""
    episodes: int
    """Rollouts; episode i starts from the scene of env seed `episode_seed(seed, i)`."""
    seed: int = 0
    """Evaluation seed: fixes every episode's scene and prompt."""
    max_steps: int | None = None
    """Step limit per rollout; None uses the task's own horizon."""
    prompt_source: str = "generated"
    """Where prompt demonstrations come from (`generated` or `human`)."""
    prompt_task: str | None = None
    """Draw prompts from this task's demonstrations instead of `task`'s (prompt ablation)."""
    prompt_steps: int | None = None
    """Keep only the first this many steps of each prompt demonstration (None: whole)."""
    scenes: str = "generated"
    """Scene distribution of the episodes: `generated`, or `human` (Table VI; kitchen only)."""
    record_version: int = EVAL_RECORD_VERSION
    """What its record holds (`EVAL_RECORD_VERSION`)."""
    suite_version: int = SUITE_VERSION
    """The task suites' version the episodes are played on (`SUITE_VERSION`)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.record_version != EVAL_RECORD_VERSION:
            raise ConfigError(f"EvalSpec.record_version {self.record_version}: this code "
                             f"computes evaluation records of version {EVAL_RECORD_VERSION}")


@dataclass(frozen=True)
class FeatureSpec(Checked):
    """Latent features of held-out trajectories through a trained policy's tokenizer (Table III)."""

    CHOICES = {"sampling": ("per_task", "task_order")}

    data: DataSpec
    """The held-out demonstrations: indices [start, start + demos_per_task) of each data set."""
    start: int
    """Index of the first held-out demonstration (the training run used the ones before)."""
    steps: int
    """Latent features scored in all (the paper: 500), drawn as `sampling` says."""
    view_steps: int = 10
    """Fig. 4: steps of the first trajectory whose latents are kept for the t-SNE plot."""
    sampling: str = "per_task"
    """`per_task`: an equal share of `steps` from every task; `task_order`: the first `steps`
    of the trajectories in task order."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.sampling == "per_task" and self.steps // len(self.data.tasks) < 3:
            raise ConfigError(f"FeatureSpec.steps {self.steps} gives each of the "
                              f"{len(self.data.tasks)} tasks fewer than the 3 steps a least "
                              f"energy needs: raise it to at least {3 * len(self.data.tasks)}")


def eval_key(run: RunSpec, ev: EvalSpec) -> str:
    """The content key of evaluating `run`'s policy as `ev` says."""
    return spec_key({"run": run, "eval": ev})


def feature_key(run: RunSpec, spec: FeatureSpec) -> str:
    """The content key of measuring `run`'s tokenizer features as `spec` says."""
    return spec_key({"run": run, "features": spec})


def run_spec(preset: Preset, policy: str = "icrt", tokenizer: str | TokenizerConfig | None = None,
             tasks: Sequence[str] | None = None, source: str = "generated",
             obs: str | None = None, seed: int | None = None,
             data_set: int | None = None) -> RunSpec:
    """The run a preset describes for `policy` (+ `tokenizer`: a registry name, a config, or
    None for the policy's default) on `tasks` (default the preset's RoboCasa tasks).
    `data_set` defaults to k for training seed preset.seed + k (`seeding.data_set_seed`);
    an image-only policy (MCR) reads `rgb` where `obs` is `state`."""
    policy_cfg = preset.policies.get(policy)
    if isinstance(tokenizer, str):
        tokenizer = preset.tokenizers.get(tokenizer)
    elif tokenizer is None:
        default = resolve_tokenizer(policy, None)
        tokenizer = preset.tokenizers.get(default.type) if default is not None else None
    tokenizer = resolve_tokenizer(policy, tokenizer)
    seed = preset.seed if seed is None else int(seed)
    if data_set is None:
        data_set = max(0, seed - preset.seed)
    tasks = tuple(tasks or preset.data.robocasa_tasks)
    exceptions = task_demo_counts(preset.data.task_demos)
    obs = obs or preset.data.obs
    if obs == "state" and policy_cfg.needs_images:
        obs = "rgb"
    data = DataSpec(tasks=tasks, source=source, obs=obs,
                    demos_per_task=preset.data.demos_per_task,
                    task_demos=tuple(f"{t}:{exceptions[t]}" for t in tasks if t in exceptions),
                    seed=data_set_seed(preset.seed, data_set))
    return RunSpec(data=data, policy=policy_cfg, tokenizer=tokenizer, train=preset.train,
                   seed=seed)


def eval_spec(preset: Preset, task: str, episodes: int | None = None, seed: int | None = None,
              prompt_source: str = "generated", prompt_task: str | None = None,
              prompt_steps: int | None = None, max_steps: int | None = None,
              scenes: str = "generated") -> EvalSpec:
    """The evaluation a preset describes on `task` (episodes by suite, else `preset.eval`)."""
    default = preset.tables.episodes_for(task, preset.eval.episodes_per_task)
    return EvalSpec(task=task, episodes=default if episodes is None else int(episodes),
                    seed=preset.seed if seed is None else int(seed),
                    max_steps=preset.eval.max_steps if max_steps is None else max_steps,
                    prompt_source=prompt_source, prompt_task=prompt_task,
                    prompt_steps=prompt_steps, scenes=scenes)


def tasks_tag(tasks: Sequence[str]) -> str:
    """A short folder tag for a task list: the task itself, or its suite (`mixed` if several)."""
    if len(tasks) == 1:
        return tasks[0].replace("/", "-")
    suites = {t.split("/", 1)[0] for t in tasks}
    return suites.pop() if len(suites) == 1 else "mixed"
