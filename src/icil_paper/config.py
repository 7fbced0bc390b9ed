"""Experiment configuration: dataclasses with a docstring under every field, and the presets.

A preset is one frozen object holding every knob: data, one config per registered tokenizer
and policy (`ComponentConfigs`), training, evaluation, tokenizer studies and tables.

- `smoke`: seconds; what the test suite runs.
- `small`: what CI's `make reproduce` runs on 2 CPU cores.
- `reference`: numbers worth reading, on 2 CPU cores.
- `full`:  the paper's scale (500K / 30K iterations, 50 rollouts per task), for GPUs.

Choose one with `get_preset(name)` (or `--preset`, `$ICIL_PRESET`; default `small`) and change
any field with `preset.with_overrides(["train.steps=3"])` (the CLI's `--set`).
"""

from __future__ import annotations

import dataclasses
import os
import types
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from icil_paper import paper_numbers, plugins
from icil_paper.benchmark_tasks import ML45_HELD_OUT, ML45_TRAIN, ROBOCASA_TASKS
from icil_paper.config_data import (
    KEYED_WHEN_SET,
    NOT_KEYED,
    Checked,
    ConfigError,
    OverrideError,
    field_docs,
    from_dict,
    with_overrides,
)
from icil_paper.policies.configs import POLICY_REGISTRY
from icil_paper.registry import ComponentRegistry, check_name
from icil_paper.tokenizers.configs import (
    TOKENIZER_REGISTRY,
    LipschitzOptions,
    TokenizerStudyConfig,
)

PRESET_NAMES = ("smoke", "small", "reference", "full")
DEFAULT_PRESET = "small"
PRESET_ENV_VAR = "ICIL_PRESET"
DATA_ENV_VAR = "ICIL_DATA"
"""Names the data folder (`DataConfig.root`) for the presets `get_preset` returns."""
OBS_KINDS = ("state", "rgb", "rgbd")
"""Observation kinds (`icil_paper.sim.OBS_KINDS`, named here so configs stay light)."""
DEMO_SOURCES = ("generated", "human")
"""Demonstration sources (`icil_paper.data.sources.SOURCES`)."""


def task_demo_counts(entries: Sequence[str]) -> dict[str, int]:
    """{task: demonstrations} from `TASK:N` entries; ConfigError for a bad or repeated one."""
    counts: dict[str, int] = {}
    for entry in entries:
        task, sep, n = str(entry).rpartition(":")
        if not sep or not task or not n.strip().isdigit() or int(n) < 1:
            raise ConfigError(f"task_demos entry {entry!r} is not TASK:N with N >= 1 "
                              "(e.g. kitchen/open_drawer:10)")
        if task in counts:
            raise ConfigError(f"task_demos names {task} twice")
        counts[task] = int(n)
    return counts


@dataclass(frozen=True)
class DataConfig(Checked):
    """Which demonstrations are generated and how."""

    CHOICES = {"obs": OBS_KINDS, "sources": DEMO_SOURCES}

    demos_per_task: int = 20
    """Successful demonstrations kept per task and source."""
    task_demos: tuple[str, ...] = field(default=(), metadata=KEYED_WHEN_SET)
    """Exceptions to `demos_per_task`, each `TASK:N` (`kitchen/open_drawer:10`)."""
    sources: tuple[str, ...] = ("generated", "human")
    """Demonstration sources: `generated` (our MimicGen stand-in) and `human` (teleoperation-like)."""
    robocasa_tasks: tuple[str, ...] = ROBOCASA_TASKS
    """Tasks of the paper's RoboCasa tables (I, III, IV, VI, Fig. 5): Meta-World stand-ins."""
    zero_shot_tasks: tuple[str, ...] = ML45_TRAIN
    """Table VII's training tasks: Meta-World's ML45 training split (45 tasks)."""
    zero_shot_held_out: tuple[str, ...] = ML45_HELD_OUT
    """Table VII's evaluation tasks, never trained on: ML45's five held-out tasks."""
    maniskill_tasks: tuple[str, ...] = (
        "maniskill/pick_cube",
        "maniskill/push_cube",
        "maniskill/stack_cube",
    )
    """ManiSkill tasks of Table II."""
    obs: str = "state"
    """Observation kind recorded and learned from: `state`, `rgb` or `rgbd`."""
    workers: int = field(default=2, metadata=NOT_KEYED)
    """Processes that generate demonstrations in parallel (the demos do not depend on it)."""
    root: str | None = field(default=None, metadata=NOT_KEYED)
    """Folder of the data sets (None: `data/` in the repository; `get_preset` reads $ICIL_DATA)."""
    expert_seeds: int = 50
    """Random scenes per task on which the `experts` stage measures every expert; 0 skips it."""

    def __post_init__(self) -> None:
        super().__post_init__()
        task_demo_counts(self.task_demos)
        held_out = set(self.zero_shot_held_out) | set(ML45_HELD_OUT)
        leaked = [t for t in self.zero_shot_tasks if t in held_out]
        if leaked:
            raise ConfigError(f"data.zero_shot_tasks names {', '.join(leaked)}, held out for "
                              "the zero-shot table (Table VII evaluates on it): remove it from "
                              "the training tasks")


class ComponentConfigs(Mapping[str, Any]):
    """One config per registered component, by attribute name (`lip-mlp` is `lip_mlp`):
    `preset.tokenizers.lipvq`, `preset.tokenizers.get("lip-mlp")`, `dict(preset.tokenizers)`.
    Immutable; `replace(vq=...)` gives a changed copy."""

    REGISTRY: ClassVar[ComponentRegistry]

    def __init__(self, **configs: Any):
        registered = self.registered()
        unknown = sorted(set(configs) - set(registered))
        if unknown:
            raise TypeError(f"{type(self).__name__} has no {self.REGISTRY.kind}(s) {unknown}; "
                            f"registered: {', '.join(registered)}")
        object.__setattr__(self, "_configs", {
            attr: configs[attr] if attr in configs else config()
            for attr, config in registered.items()})

    @classmethod
    def registered(cls) -> dict[str, type]:
        """attribute name -> config class of every component registered now (plugins included)."""
        plugins.discover()
        return {name.replace("-", "_"): config for name, config in cls.REGISTRY.configs.items()}

    @classmethod
    def build(cls, shared: Mapping[str, Any],
              per_component: Mapping[str, Mapping[str, Any]] = types.MappingProxyType({})):
        """The section built from preset values: `shared` goes to every config with a field
        of that name, `per_component[name]` to `name` and its subclasses (`fsq` -> `lipfsq`)."""
        configs = cls.REGISTRY.configs
        unknown = sorted(set(per_component) - set(configs))
        if unknown:
            raise ValueError(f"preset values for unregistered {cls.REGISTRY.kind}(s) {unknown}")
        values = {}
        for name, config in configs.items():
            names = {f.name for f in dataclasses.fields(config)}
            kwargs = {k: v for k, v in shared.items() if k in names}
            for other, extra in per_component.items():
                if issubclass(config, configs[other]):
                    kwargs.update(extra)
            values[name.replace("-", "_")] = config(**kwargs)
        return cls(**values)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]):
        """The section `to_dict` wrote (OverrideError for a name no component has)."""
        registered = cls.registered()
        unknown = sorted(set(data) - set(registered))
        if unknown:
            raise OverrideError(f"{cls.__name__} has no {cls.REGISTRY.kind}(s) {unknown}; "
                                f"valid: {sorted(registered)}")
        return cls(**{a: from_dict(registered[a], v) for a, v in data.items()})

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """attribute name -> the first paragraph of its config class's docstring."""
        return {attr: " ".join((config.__doc__ or "").strip().split("\n\n")[0].split())
                for attr, config in cls.registered().items()}

    def get(self, name: str):  # noqa: D102 (a registry name, not Mapping.get's default)
        """The config of component `name` (`lip-mlp` or `lip_mlp`)."""
        attr = name.replace("-", "_")
        if attr not in self._configs:
            check_name(self.REGISTRY.kind, name, [n for n in self.REGISTRY.configs
                                                  if n.replace("-", "_") in self._configs])
        return self._configs[attr]

    def replace(self, **changes: Any):
        """A copy with some components' configs replaced."""
        return type(self)(**{**self._configs, **changes})

    def __getitem__(self, attr: str):
        return self._configs[attr]

    def __iter__(self) -> Iterator[str]:
        return iter(self._configs)

    def __len__(self) -> int:
        return len(self._configs)

    def __getattr__(self, attr: str):
        if attr.startswith("_"):  # pickle and copy probe for hooks before __init__ ran
            raise AttributeError(attr)
        try:
            return self._configs[attr]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no {self.REGISTRY.kind} "
                                 f"{attr!r}") from None

    def __setattr__(self, attr: str, value: Any) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot assign to {attr!r}: "
                                              "use .replace(...)")

    def __hash__(self) -> int:
        return hash(tuple(self._configs.items()))

    def __repr__(self) -> str:
        inner = ", ".join(f"{a}={c!r}" for a, c in self._configs.items())
        return f"{type(self).__name__}({inner})"


class TokenizerConfigs(ComponentConfigs):
    """One config per registered action tokenizer (Sec. III-B), by registry name."""

    REGISTRY = TOKENIZER_REGISTRY


class PolicyConfigs(ComponentConfigs):
    """One config per registered policy, by registry name."""

    REGISTRY = POLICY_REGISTRY


@dataclass(frozen=True)
class TrainConfig(Checked):
    """The one training loop shared by every policy."""

    steps: int = 2000
    """Optimizer steps."""
    batch_size: int = 16
    """Sequences per batch."""
    lr: float = 5e-4
    """Peak learning rate (ICRT's)."""
    weight_decay: float = 0.01
    """AdamW weight decay."""
    betas: tuple[float, float] = (0.9, 0.95)
    """AdamW betas."""
    warmup_steps: int = 100
    """Linear warm-up steps before the half-cycle cosine decay."""
    grad_clip: float = 1.0
    """Gradient norm clip."""
    ema_decay: float | None = None
    """Decay of an exponential moving average of weights, or None for no EMA."""
    ckpt_every: int = field(default=500, metadata=NOT_KEYED)
    """Steps between checkpoints (a killed run loses at most this many)."""
    log_every: int = field(default=10, metadata=NOT_KEYED)
    """Steps between lines of the metrics JSONL file."""
    cpu_threads: int = field(default=1, metadata=NOT_KEYED)
    """torch CPU threads while training on CPU; 0 keeps torch's default."""


@dataclass(frozen=True)
class EvalConfig(Checked):
    """Rollouts that turn a trained policy into a success rate."""

    episodes_per_task: int = 10
    """Rollouts per task (the paper: 50)."""
    max_steps: int | None = None
    """Step limit per rollout; None uses the task's own horizon."""
    workers: int = field(default=2, metadata=NOT_KEYED)
    """Processes that run rollouts in parallel (each episode is fixed by its seed alone)."""
    record: bool = field(default=False, metadata=NOT_KEYED)
    """Write a rerun recording of every rollout."""


CLAIM_IDS = (
    "I-lipvq-best", "I-lipvq-vs-bc", "I-lipvq-vs-lfq", "I-tokenizer-gap", "I-mlp-below-bc",
    "II-lipvq-best", "II-lipvq-vs-lfq", "II-lipvq-vs-act", "III-lipvq-smoothest",
    "III-smoother-succeeds", "IV-mlp", "IV-vq", "IV-vq-over-mlp", "fig5-best",
    "V-lipvq-vs-bc", "V-lipvq-vs-bin", "V-lipvq-smoother-motion", "VI-mlp-vs-bc",
    "VI-lipvq-best", "VII-lipvq-vs-bc", "VII-lipvq-best", "beyond-eq4-fsq", "beyond-eq4-rvq",
    "III-smoother-latents-smoother-motion")
"""Every claim of the ledger by id, in its order (declared in `icil_paper.paper`)."""

PRIMARY_CLAIMS = ("I-lipvq-vs-bc", "II-lipvq-vs-act", "III-lipvq-smoothest", "IV-vq",
                  "V-lipvq-vs-bc", "V-lipvq-smoother-motion")
"""The primary family: the claims that carry the paper's three questions; the rest are secondary."""

FAMILY_WEIGHTS = (0.8, 0.2)
"""Shares of the familywise 5% given to the primary and the secondary family."""

CONTINUATION_POWER = 0.1
"""A claim's rows go on to the next stage while its conditional power is at least this."""


@dataclass(frozen=True)
class TablesConfig(Checked):
    """The paper's tables and figures: seeds, sweeps, sizes and the claims ledger's design."""

    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"primary_claims": CLAIM_IDS}

    icrt_seeds: int = 1
    """Training seeds of every ICRT row of Table I (and of Tables III-VI, which share them)."""
    baseline_seeds: int = 1
    """Training seeds of Table I's other rows (MCR, ACT, BC-Transformer)."""
    codebook_sizes: tuple[int, ...] = (256, 512, 1024, 2048)
    """Fig. 5: the LipVQ-VAE codebook sizes swept (the paper: 2^8 .. 2^11)."""
    image_demos_per_task: int = 10
    """Demonstrations per task of MCR's image data sets."""
    image_episodes_per_task: int = 10
    """Rollouts per task of MCR's image evaluations."""
    image_max_steps: int | None = None
    """Step limit of MCR's image rollouts; None: the evaluation's (`eval.max_steps`)."""
    feature_demos_per_task: int = 2
    """Table III: held-out generated demonstrations per task whose actions the tokenizers embed."""
    feature_steps: int = 500
    """Table III: latent features scored (the paper: 500), an equal share from every task."""
    prompt_steps: int = 10
    """Prompt ablation: steps kept of the truncated prompt."""
    maniskill_demos_per_task: int | None = None
    """Table II: demonstrations per ManiSkill task; None: `data.demos_per_task`."""
    maniskill_steps: int | None = None
    """Table II: optimizer steps of its state-based rows; None: `train.steps`."""
    maniskill_episodes_per_task: int | None = None
    """Table II: rollouts per task of its state-based rows; None: `eval.episodes_per_task`."""
    since_paper_seeds: int | None = None
    """Training seeds of every row of the `beyond` table; None: `icrt_seeds`."""
    official_seeds: int | None = None
    """Training seeds of every row of the `official` table; None: `icrt_seeds`."""
    row_seeds: tuple[str, ...] = ()
    """Training seeds of single rows, as "TABLE:row=N" ("I:icrt+lipvq=10"; "TABLE:*=N" for
    every row no entry names); other rows keep their table's default."""
    scenes_per_seed: bool = False
    """True: training seed k of every row is evaluated on its own scene set k; False: one set."""
    seed_stages: tuple[int, ...] = ()
    """Seeds a row has at each look of the sequential design, e.g. (5, 10, 15); empty: fixed."""
    stage_budget_hours: float | None = None
    """The most a run in stages may cost, in hours (`planning.design.plan_cost`); None: no budget."""
    stage_stops: tuple[str, ...] = ()
    """Claims the budget stopped at a look (set by `planning.staged.staged_preset`)."""
    primary_claims: tuple[str, ...] = PRIMARY_CLAIMS
    """The primary family of the claims ledger, by claim id; empty: one family (Holm)."""
    family_weights: tuple[float, ...] = FAMILY_WEIGHTS
    """(primary, secondary): the shares of the familywise level, summing to 1."""
    continuation_power: float = CONTINUATION_POWER
    """An undecided claim's rows go on while its conditional power is at least this."""
    episodes_per_task_by_suite: tuple[str, ...] = ()
    """Rollouts per task of state-based evaluations by suite, as "SUITE=N" ("kitchen=10")."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.seeds_by_row()
        self.episodes_by_suite()
        stages = self.seed_stages
        if stages and (stages[0] < 2 or any(b <= a for a, b in zip(stages[:-1], stages[1:], strict=True))):
            raise ConfigError(f"TablesConfig.seed_stages: {stages} should be increasing seed "
                              "counts, each at least 2, e.g. 5,10,15")
        weights = self.family_weights
        if len(weights) != 2 or abs(sum(weights) - 1) > 1e-9:
            raise ConfigError(f"TablesConfig.family_weights: {weights} should be the primary "
                              "and secondary families' shares of the level, summing to 1, "
                              "e.g. 0.8,0.2")
        if len(set(self.primary_claims)) != len(self.primary_claims):
            raise ConfigError(f"TablesConfig.primary_claims: {self.primary_claims} names a "
                              "claim twice")
        if not 0 <= self.continuation_power < 1:
            raise ConfigError(f"TablesConfig.continuation_power: {self.continuation_power} "
                              "should be a probability below 1, e.g. 0.1")

    def episodes_by_suite(self) -> dict[str, int]:
        """`episodes_per_task_by_suite` as {suite: episodes}."""
        out = {}
        for entry in self.episodes_per_task_by_suite:
            suite, sep, number = entry.partition("=")
            if not sep or not suite.strip() or not number.strip().isdigit() or int(number) < 1:
                raise ConfigError(f"TablesConfig.episodes_per_task_by_suite: {entry!r} should "
                                  "read SUITE=N with N >= 1 episodes, e.g. kitchen=10")
            out[suite.strip()] = int(number)
        return out

    def episodes_for(self, task: str, default: int) -> int:
        """Rollouts per task of a state-based evaluation on `task`, else `default`."""
        return self.episodes_by_suite().get(task.split("/", 1)[0], default)

    def seeds_by_row(self) -> dict[str, int]:
        """`row_seeds` as {"TABLE:row": seeds}."""
        out = {}
        for entry in self.row_seeds:
            name, sep, number = entry.rpartition("=")
            if not sep or ":" not in name or not number.strip().isdigit() or int(number) < 1:
                raise ConfigError(f"TablesConfig.row_seeds: {entry!r} should read "
                                  "TABLE:row=N with N >= 1, e.g. I:icrt+lipvq=10")
            out[name.strip()] = int(number)
        return out


@dataclass(frozen=True)
class Preset(Checked):
    """Everything a run depends on besides code: one object, saved with every result."""

    name: str = DEFAULT_PRESET
    """Preset name: smoke, small, reference or full."""
    seed: int = 0
    """Seed of the data and default training and evaluation seed."""
    data: DataConfig = field(default_factory=DataConfig)
    """Demonstration data."""
    tokenizers: TokenizerConfigs = field(default_factory=TokenizerConfigs)
    """One config per action tokenizer."""
    policies: PolicyConfigs = field(default_factory=PolicyConfigs)
    """One config per policy."""
    train: TrainConfig = field(default_factory=TrainConfig)
    """Training loop."""
    eval: EvalConfig = field(default_factory=EvalConfig)
    """Evaluation rollouts."""
    tokenizer_study: TokenizerStudyConfig = field(default_factory=TokenizerStudyConfig)
    """Tokenizers trained alone (chapters 03 and 05)."""
    tables: TablesConfig = field(default_factory=TablesConfig)
    """The paper's tables and figures."""

    def with_overrides(self, overrides: Sequence[str]) -> Preset:
        """A copy with `SECTION.FIELD=VALUE` overrides applied (the CLI's `--set`)."""
        return with_overrides(self, overrides)

    def replace(self, **sections: Any) -> Preset:
        """A copy with some fields changed: `preset.replace(train={"steps": 10})`."""
        changes = {}
        for key, value in sections.items():
            current = getattr(self, key)
            if dataclasses.is_dataclass(current) and isinstance(value, dict):
                value = dataclasses.replace(current, **value)
            changes[key] = value
        return dataclasses.replace(self, **changes)


def schedule_sum(warmup: int, steps: int) -> float:
    """sum_t schedule(t) over `steps` steps of the trainer's schedule (linear warm-up, then a
    half-cycle cosine: `train.optim.cosine_schedule`), in closed form."""
    if steps <= 0:
        return 0.0
    if warmup >= steps:
        return steps * (steps + 1) / (2 * max(1, warmup))
    return (warmup + 1) / 2 * (warmup > 0) + (steps - warmup + 1) / 2


def bound_travel(train: TrainConfig, c_lr_scale: float = 1.0) -> float:
    """The farthest Adam can move a Lipschitz bound c_l in a run: lr * c_lr_scale *
    `schedule_sum` (chapter 03)."""
    return train.lr * c_lr_scale * schedule_sum(train.warmup_steps, train.steps)


PAPER_TRAIN = TrainConfig(steps=paper_numbers.ITERATIONS["kitchen"], warmup_steps=2000)
"""The paper's RoboCasa training: 500K iterations, 2000 warm-up steps."""
PAPER_MANISKILL_TRAIN = TrainConfig(steps=paper_numbers.ITERATIONS["maniskill"], warmup_steps=2000)
"""The paper's ManiSkill training: 30K iterations."""


def matching_c_lr_scale(train: TrainConfig, paper: TrainConfig = PAPER_TRAIN) -> float:
    """The `LipschitzOptions.c_lr_scale` at which the bounds travel as far in `train` as in
    the paper's run: bound_travel(paper) / bound_travel(train)."""
    return bound_travel(paper) / bound_travel(train)


def _lipschitz_twins(train: TrainConfig, c_lr_scale: float | None = None
                     ) -> dict[str, dict[str, Any]]:
    """The Lipschitz tokenizers' options: nn.Linear's initialisation, so each starts as its
    plain twin, and bounds that travel as far as in the paper (`matching_c_lr_scale`)."""
    scale = matching_c_lr_scale(train) if c_lr_scale is None else c_lr_scale
    options = LipschitzOptions(weight_init="linear", c_lr_scale=round(scale, 3))
    return {name: {"lipschitz": options} for name in ("lip-mlp", "lipvq", "lipfsq", "liprvq")}


def _tokenizers(latent_dim: int, codebook_size: int, **per_tokenizer: dict[str, Any]
                ) -> TokenizerConfigs:
    """Every tokenizer at one width and codebook size, plus each one's own values by name."""
    return TokenizerConfigs.build(dict(latent_dim=latent_dim, codebook_size=codebook_size),
                                  per_tokenizer)


def _smoke() -> Preset:
    train = TrainConfig(steps=5, batch_size=2, warmup_steps=1, ckpt_every=2, log_every=1)
    return Preset(
        name="smoke",
        data=DataConfig(demos_per_task=2, workers=1, expert_seeds=0,
                        zero_shot_tasks=("metaworld/reach", "metaworld/drawer-open"),
                        zero_shot_held_out=("metaworld/door-lock",)),
        tokenizers=_tokenizers(latent_dim=16, codebook_size=64, fast={"vocab_size": 300},
                               fsq={"levels": (4, 4, 4)},
                               rvq={"num_quantizers": 2, "codebook_size": 8},
                               bspline={"chunk": 4, "control_points": 4, "n_bins": 32},
                               **_lipschitz_twins(train)),
        policies=PolicyConfigs.build(dict(  # every policy at one size (where it has the field)
            d_model=32, n_layer=1, n_head=2, dropout=0.0, chunk_size=2, history=4,
            max_seq_len=1024, resnet_width=8, query_len=8, pretrain_steps=3, language=True)),
        train=train,
        eval=EvalConfig(episodes_per_task=1, max_steps=10, workers=1),
        tokenizer_study=TokenizerStudyConfig(steps=30, batch_size=8, window=8, n_trajectories=12,
                                             n_eval_trajectories=4, bench_fast_actions=20_000,
                                             seeds=1),
        tables=TablesConfig(icrt_seeds=1, codebook_sizes=(16, 32, 64, 128),
                            image_demos_per_task=1, image_episodes_per_task=1,
                            feature_demos_per_task=1, feature_steps=40),
    )


def _small_tokenizers(train: TrainConfig) -> TokenizerConfigs:
    """The small and reference presets' tokenizers (bounds matched to `train`)."""
    return _tokenizers(latent_dim=32, codebook_size=256, fsq={"levels": (8, 6, 5)},
                       rvq={"num_quantizers": 2, "codebook_size": 16},
                       bspline={"chunk": 8, "control_points": 5, "n_bins": 256},
                       **_lipschitz_twins(train))


def _small() -> Preset:
    # CI computes every table within minutes: short training, one episode per task.
    train = TrainConfig(steps=200, batch_size=8, warmup_steps=30, ckpt_every=100)
    return Preset(
        name="small",
        data=DataConfig(demos_per_task=10, workers=2, expert_seeds=0),
        tokenizers=_small_tokenizers(train),
        policies=PolicyConfigs.build(dict(
            d_model=64, n_layer=2, n_head=2, dropout=0.0, chunk_size=4, history=10,
            max_seq_len=2048, resnet_width=16, query_len=0, pretrain_steps=100, language=True)),
        train=train,
        eval=EvalConfig(episodes_per_task=1, max_steps=150, workers=2),
        tokenizer_study=TokenizerStudyConfig(steps=400, n_trajectories=64, n_eval_trajectories=16),
        tables=TablesConfig(icrt_seeds=1, codebook_sizes=(64, 128, 256, 512),
                            image_demos_per_task=2, image_episodes_per_task=1,
                            image_max_steps=40, feature_demos_per_task=1,
                            primary_claims=PRIMARY_CLAIMS, family_weights=FAMILY_WEIGHTS,
                            continuation_power=CONTINUATION_POWER,
                            episodes_per_task_by_suite=()),
    )


REFERENCE_ROW_SEEDS = (
    "I:mcr=5",  # image rows: no claim reads them; ten times a state cell on CPU
    "II:*=10", "II:bc_transformer=5", "II:mcr=3",  # every ACT row: see `_reference`
    "VII:*=5", "VII:mcr=3",
    "fig5:*=5",
    "analysis:*=3",  # no claim reads them; chapter 11's own comparisons
)
"""The reference preset's seeds of single rows (`TablesConfig.row_seeds`)."""


REFERENCE_SEED_STAGES = (5, 10, 15)
"""The reference preset's looks (`TablesConfig.seed_stages`)."""


REFERENCE_BUDGET_HOURS = 12.0
"""The reference run's budget in hours (`TablesConfig.stage_budget_hours`)."""

REFERENCE_SEED = 5000
"""The reference run's base seed, disjoint from the seeds earlier runs and pilots drew."""

REFERENCE_EPISODES = ("kinova=7", "maniskill=56", "metaworld=20")
"""The reference preset's cost-optimal rollouts per task by suite."""


REGIME_DEMOS, REGIME_STEPS = 50, 500
"""The reference preset's demonstrations per task and training steps (the regime pilot's)."""
REGIME_TASK_DEMOS: tuple[str, ...] = ()
"""The reference preset's tasks with demonstration counts of their own (`data.task_demos`)."""


def _reference() -> Preset:
    """The committed reference run (sizes from the regime pilot)."""
    small = _small()
    train = TrainConfig(steps=REGIME_STEPS, batch_size=8, warmup_steps=100, ckpt_every=500)
    return dataclasses.replace(
        small, name="reference", seed=REFERENCE_SEED,
        data=DataConfig(demos_per_task=REGIME_DEMOS, task_demos=REGIME_TASK_DEMOS, workers=2,
                        expert_seeds=0),
        tokenizers=_small_tokenizers(train),
        train=train,
        eval=EvalConfig(episodes_per_task=5, workers=2),
        tokenizer_study=TokenizerStudyConfig(steps=2000, n_trajectories=200,
                                             n_eval_trajectories=50),
        tables=TablesConfig(icrt_seeds=10, baseline_seeds=10, codebook_sizes=(64, 128, 256, 512),
                            image_demos_per_task=5, image_episodes_per_task=2,
                            feature_demos_per_task=1, maniskill_demos_per_task=40,
                            maniskill_steps=5000, maniskill_episodes_per_task=10,
                            since_paper_seeds=5, official_seeds=5,
                            row_seeds=REFERENCE_ROW_SEEDS, scenes_per_seed=True,
                            seed_stages=REFERENCE_SEED_STAGES,
                            stage_budget_hours=REFERENCE_BUDGET_HOURS,
                            primary_claims=PRIMARY_CLAIMS, family_weights=FAMILY_WEIGHTS,
                            continuation_power=CONTINUATION_POWER,
                            episodes_per_task_by_suite=REFERENCE_EPISODES),
    )


def _full() -> Preset:
    return Preset(
        name="full",
        data=DataConfig(demos_per_task=200, workers=16, obs="rgb"),
        tokenizers=_tokenizers(latent_dim=64, codebook_size=1024, fsq={"levels": (8, 5, 5, 5)},
                               rvq={"num_quantizers": 2, "codebook_size": 32},
                               bspline={"chunk": 16, "control_points": 8, "n_bins": 256},
                               **_lipschitz_twins(PAPER_TRAIN, c_lr_scale=1.0)),
        policies=PolicyConfigs.build(dict(
            d_model=512, n_layer=6, n_head=8, dropout=0.1, chunk_size=16, history=10,
            max_seq_len=4096, resnet_width=64, query_len=0, pretrain_steps=20000, language=True)),
        train=TrainConfig(steps=500_000, batch_size=32, warmup_steps=2000, ckpt_every=5000,
                          ema_decay=0.999, cpu_threads=0),
        eval=EvalConfig(episodes_per_task=50, workers=16),
        tokenizer_study=TokenizerStudyConfig(steps=20000, n_trajectories=2000,
                                             n_eval_trajectories=200),
        # The paper's protocol: 50 rollouts per task, images, codebooks 2^8 .. 2^11.
        tables=TablesConfig(icrt_seeds=3, codebook_sizes=(256, 512, 1024, 2048),
                            image_demos_per_task=200, image_episodes_per_task=50,
                            feature_demos_per_task=2, since_paper_seeds=5, official_seeds=5),
    )


_PRESETS = {"smoke": _smoke, "small": _small, "reference": _reference, "full": _full}


def active_preset_name(name: str | None = None) -> str:
    """The preset name in force: `name` if given, else $ICIL_PRESET, else `small`."""
    name = name or os.environ.get(PRESET_ENV_VAR) or DEFAULT_PRESET
    return check_name("preset", name, PRESET_NAMES)


def get_preset(name: str | None = None, seed: int | None = None) -> Preset:
    """The named preset (see `active_preset_name`), optionally with another seed; its data
    folder is $ICIL_DATA when set (`DataConfig.root`)."""
    preset = _PRESETS[active_preset_name(name)]()
    data_folder = os.environ.get(DATA_ENV_VAR, "").strip()  # an empty value counts as unset
    if data_folder:
        preset = preset.replace(data={"root": data_folder})
    if seed is not None:
        preset = dataclasses.replace(preset, seed=seed)
    return preset


__all__ = ["PRESET_NAMES", "DataConfig", "EvalConfig", "Preset", "PolicyConfigs",
           "TokenizerConfigs", "TokenizerStudyConfig", "TrainConfig", "active_preset_name",
           "field_docs", "get_preset"]
