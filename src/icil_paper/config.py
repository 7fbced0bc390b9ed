"""Experiment configuration: dataclasses with a docstring under every field, and three presets.

- `smoke`: seconds; what the test suite runs.
- `small`: what CI's `make reproduce` runs on 2 CPU cores (at most 30 minutes in all).
- `full`:  the paper's scale (500K / 30K iterations, 50 rollouts per task), for GPUs.

The preset is chosen by `--preset` on the CLI or the `ICIL_PRESET` environment variable
(default `small`). `get_preset("nope")` raises an UnknownNameError listing the valid names.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from typing import Any

from icil_paper.registry import check_name

PRESET_NAMES = ("smoke", "small", "full")
DEFAULT_PRESET = "small"
PRESET_ENV_VAR = "ICIL_PRESET"


@dataclass(frozen=True)
class DataConfig:
    """Which demonstrations are generated and how."""

    demos_per_task: int = 20
    """Successful demonstrations kept per task and source."""
    sources: tuple[str, ...] = ("generated", "human")
    """Demonstration sources: `generated` (our MimicGen stand-in) and `human` (teleoperation-like)."""
    kitchen_tasks: tuple[str, ...] = (
        "kitchen/pick_place",
        "kitchen/open_door",
        "kitchen/close_door",
        "kitchen/open_drawer",
        "kitchen/close_drawer",
        "kitchen/turn_lever_on",
        "kitchen/turn_lever_off",
        "kitchen/twist_knob_on",
        "kitchen/twist_knob_off",
        "kitchen/insertion",
        "kitchen/press_button",
    )
    """Kitchen skill tasks (our robosuite stand-in for RoboCasa's seven skill families)."""
    maniskill_tasks: tuple[str, ...] = (
        "maniskill/pick_cube",
        "maniskill/push_cube",
        "maniskill/stack_cube",
    )
    """ManiSkill tasks of Table II."""
    obs: str = "state"
    """Observation kind recorded and learned from: `state`, `rgb` or `rgbd`."""
    workers: int = 2
    """Processes that generate demonstrations in parallel."""
    expert_seeds: int = 50
    """Random scenes per task on which the `experts` stage measures every expert (success,
    open-loop replay, human-source keep rate); 0 skips it, and chapter 03 then reports the
    experts' success over the scenes the data sets were generated on."""


@dataclass(frozen=True)
class TokenizerConfig:
    """Action tokenizers (Sec. III-B) and their stand-alone training (chapter 04)."""

    latent_dim: int = 64
    """Width D of the action embedding (and of each codebook entry)."""
    codebook_size: int = 1024
    """Codebook size K of vq / lipvq (the paper's default, 2^10)."""
    n_bins: int = 256
    """Uniform bins per action dimension for the RT-1 style `bin` tokenizer."""
    fast_scale: float = 10.0
    """FAST: DCT coefficients are multiplied by this before rounding."""
    fast_vocab_size: int = 1024
    """FAST: BPE vocabulary size."""
    fast_chunk: int = 8
    """FAST: action steps per DCT chunk."""
    steps: int = 2000
    """Optimizer steps when a tokenizer is trained on its own (chapter 04)."""
    batch_size: int = 64
    """Trajectory windows per batch when a tokenizer is trained on its own."""
    window: int = 16
    """Steps per trajectory window when a tokenizer is trained on its own."""
    lr: float = 1e-3
    """Learning rate when a tokenizer is trained on its own."""
    codebook_sizes: tuple[int, ...] = (256, 512, 1024, 2048)
    """Codebook sizes swept in the codebook-size ablation (Fig. 5)."""
    hidden: tuple[int, ...] = (64, 128)
    """Hidden widths of the tokenizers' encoder MLPs (decoders mirror them; the official code's)."""
    fast_mode: str = "causal"
    """FAST: `causal` (step t tokenized with the chunk ending at t) or `blocked` (FAST's own
    non-overlapping chunks, whose step embeddings see later actions of their chunk)."""
    trajectories: str = "demos"
    """What tokenizers are trained on alone (chapters 02 and 04): `demos`, the preset's
    `generated` demonstrations of its kitchen and ManiSkill tasks (the last `eval_fraction` of
    each task's demos held out), or `synthetic`, minimum-jerk trajectories from
    `icil_paper.trajectories` (no simulator needed)."""
    eval_fraction: float = 0.2
    """Share of each task's demonstrations held out for the tokenizer metrics (at least one)."""
    n_trajectories: int = 200
    """`synthetic` only: generated trajectories a tokenizer is trained on."""
    n_eval_trajectories: int = 50
    """`synthetic` only: held-out generated trajectories the metrics are computed on."""
    trajectory_noise: float = 0.02
    """Amplitude of the low-pass noise added to generated trajectories (teleoperation tremor)."""
    bench_fast_actions: int = 1_000_000
    """Actions FAST's BPE is fitted on in the benchmark (the paper: 1M)."""


@dataclass(frozen=True)
class PolicyConfig:
    """Transformer sizes shared by ICRT and the baselines (ACT is scaled to BC-Transformer)."""

    d_model: int = 128
    """Token width."""
    n_layer: int = 4
    """Transformer layers."""
    n_head: int = 4
    """Attention heads."""
    dropout: float = 0.1
    """Dropout inside the transformer."""
    chunk_size: int = 4
    """Future actions predicted per query step (ICRT / ACT action chunking)."""
    history: int = 10
    """Observation history of BC-Transformer (robomimic's context length)."""
    prompt_demos: int = 1
    """Full demonstrations in an ICRT prompt (the paper uses one)."""
    max_seq_len: int = 1024
    """Longest token sequence ICRT trains on and keeps in its KV cache at inference (rotary
    positions have no table limit; past this length the oldest query steps leave the cache,
    the prompt stays)."""
    query_actions: bool = True
    """ICRT: interleave the query's own past actions with its observations (s1,a1,s2,a2,...,
    as ICRT's code does); False gives Eq. 1 literally (query observations only)."""
    resnet_width: int = 64
    """First-stage channels of the ResNet-18 image backbone (torchvision's is 64)."""
    language: bool = False
    """Add a learned hashed bag-of-words embedding of the instruction to every observation
    token (stands in for CLIP, which cannot be downloaded here)."""
    act_latent_dim: int = 32
    """ACT: width of the CVAE style latent z."""
    kl_weight: float = 10.0
    """ACT: weight of the KL term of the CVAE loss."""
    ensemble_m: float = 0.01
    """ACT: temporal ensembling weights exp(-m i) over overlapping chunks."""
    mcr_pretrain_steps: int = 1000
    """MCR: steps of manipulation-centric pre-training of the visual encoder before it is
    frozen under the behaviour-cloning head."""


@dataclass(frozen=True)
class TrainConfig:
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
    ckpt_every: int = 500
    """Steps between checkpoints (a killed run loses at most this many)."""
    query_len: int = 32
    """Query steps per training sequence."""
    log_every: int = 10
    """Steps between lines of the metrics JSONL file."""
    cpu_threads: int = 1
    """torch CPU threads while training on CPU; 0 keeps torch's default. One thread is the
    default because the small models here gain little from more, and a CPU shared with other
    processes (rollout workers, a second job) makes torch's spinning thread pool many times
    slower (measured 0.23 vs 6.2 steps/s on a loaded 2-core machine)."""


@dataclass(frozen=True)
class EvalConfig:
    """Rollouts that turn a trained policy into a success rate."""

    episodes_per_task: int = 10
    """Rollouts per task (the paper: 50)."""
    max_steps: int | None = None
    """Step limit per rollout; None uses the task's own horizon."""
    workers: int = 2
    """Processes that run rollouts in parallel."""
    record: bool = False
    """Write a rerun recording of every rollout."""


@dataclass(frozen=True)
class Preset:
    """Everything a run depends on besides code: one object, saved with every result."""

    name: str = DEFAULT_PRESET
    """Preset name: smoke, small or full."""
    seed: int = 0
    """Seed passed to `seed_everything` by every entry point."""
    data: DataConfig = field(default_factory=DataConfig)
    """Demonstration data."""
    tokenizer: TokenizerConfig = field(default_factory=TokenizerConfig)
    """Action tokenizers."""
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    """Policy sizes."""
    train: TrainConfig = field(default_factory=TrainConfig)
    """Training loop."""
    eval: EvalConfig = field(default_factory=EvalConfig)
    """Evaluation rollouts."""

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (tuples become lists)."""
        return dataclasses.asdict(self)

    def replace(self, **sections: Any) -> Preset:
        """A copy with some fields changed: `preset.replace(train={"steps": 10})`."""
        changes = {}
        for key, value in sections.items():
            current = getattr(self, key)
            if dataclasses.is_dataclass(current) and isinstance(value, dict):
                value = dataclasses.replace(current, **value)
            changes[key] = value
        return dataclasses.replace(self, **changes)


def _smoke() -> Preset:
    return Preset(
        name="smoke",
        data=DataConfig(demos_per_task=2, workers=1, expert_seeds=0),
        tokenizer=TokenizerConfig(
            latent_dim=16, codebook_size=64, fast_vocab_size=300, steps=30,
            batch_size=8, window=8, codebook_sizes=(16, 32), n_trajectories=12,
            n_eval_trajectories=4, bench_fast_actions=20_000,
        ),
        policy=PolicyConfig(d_model=32, n_layer=1, n_head=2, dropout=0.0, chunk_size=2,
                            history=4, max_seq_len=512, resnet_width=8, mcr_pretrain_steps=3),
        train=TrainConfig(steps=5, batch_size=2, warmup_steps=1, ckpt_every=2, query_len=8,
                          log_every=1),
        eval=EvalConfig(episodes_per_task=1, max_steps=10, workers=1),
    )


def _small() -> Preset:
    return Preset(
        name="small",
        data=DataConfig(demos_per_task=10, workers=2, expert_seeds=0),
        tokenizer=TokenizerConfig(latent_dim=32, codebook_size=256, steps=400,
                                  codebook_sizes=(64, 128, 256, 512), n_trajectories=64,
                                  n_eval_trajectories=16),
        policy=PolicyConfig(d_model=64, n_layer=2, n_head=2, dropout=0.0, chunk_size=4,
                            max_seq_len=1024, resnet_width=16, mcr_pretrain_steps=100),
        # 1500 steps: ICRT + LipVQ-VAE on kitchen/open_drawer went from 2/10 rollouts at 300
        # steps to 10/10 at 1500 (about a minute on 2 cores, its evaluation included).
        train=TrainConfig(steps=1500, batch_size=8, warmup_steps=100, ckpt_every=500),
        eval=EvalConfig(episodes_per_task=5, workers=2),
    )


def _full() -> Preset:
    return Preset(
        name="full",
        data=DataConfig(demos_per_task=200, workers=16, obs="rgb"),
        tokenizer=TokenizerConfig(latent_dim=64, codebook_size=1024, steps=20000,
                                  n_trajectories=2000, n_eval_trajectories=200),
        policy=PolicyConfig(d_model=512, n_layer=6, n_head=8, dropout=0.1, chunk_size=16,
                            max_seq_len=4096, resnet_width=64, language=True,
                            mcr_pretrain_steps=20000),
        train=TrainConfig(steps=500_000, batch_size=32, warmup_steps=2000, ckpt_every=5000,
                          ema_decay=0.999, cpu_threads=0),
        eval=EvalConfig(episodes_per_task=50, workers=16),
    )


_PRESETS = {"smoke": _smoke, "small": _small, "full": _full}


def active_preset_name(name: str | None = None) -> str:
    """The preset name in force: `name` if given, else $ICIL_PRESET, else `small`."""
    name = name or os.environ.get(PRESET_ENV_VAR) or DEFAULT_PRESET
    return check_name("preset", name, PRESET_NAMES)


def get_preset(name: str | None = None, seed: int | None = None) -> Preset:
    """The named preset (see `active_preset_name`), optionally with another seed."""
    preset = _PRESETS[active_preset_name(name)]()
    if seed is not None:
        preset = dataclasses.replace(preset, seed=seed)
    return preset


def field_docs(cls: type) -> dict[str, str]:
    """Map each field of a config dataclass to the docstring written under it."""
    import ast
    import inspect
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    docs = {}
    for node, following in zip(body, body[1:], strict=False):
        if (isinstance(node, ast.AnnAssign) and isinstance(following, ast.Expr)
                and isinstance(following.value, ast.Constant)):
            docs[node.target.id] = str(following.value.value).strip()
    return docs
