"""One config dataclass per action tokenizer; `make_tokenizer(config, action_dim)` builds from it.

Torch-free, so that presets, the command line and result keys hold tokenizer configs
without importing the models. `@register_tokenizer(name)` registers a config class and sets
its `type`; the model class registers with `@register_tokenizer_model(name)`.

    from icil_paper.tokenizers import make_tokenizer
    from icil_paper.tokenizers.configs import LipVQConfig
    tok = make_tokenizer(LipVQConfig(latent_dim=32, codebook_size=256), action_dim=7)

Defaults are the paper's (Sec. III-B): D = 64, K = 1024, alpha 1.0, beta 0.25, gamma 1e-6.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

from icil_paper.config_data import Checked, ConfigError
from icil_paper.registry import ComponentRegistry

DEFAULT_HIDDEN = (64, 128)
TOKENIZER_CHOICES: dict[str, tuple[str, ...]] = {
    "norm": ("none", "lipschitz", "lipschitz-last", "spectral"),
    "activation": ("relu", "gelu"),
    "output_activation": ("none", "sigmoid", "tanh"),
    "straight_through": ("vqvae", "codebook", "none"),
    "codebook_init": ("uniform", "data"),
    "mode": ("causal", "blocked"),
}
"""The valid strings of the tokenizer fields of these names (checked when a config is built)."""


@dataclass(frozen=True)
class TokenizerConfig(Checked):
    """Knobs every action tokenizer has."""

    type: ClassVar[str] = ""
    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = TOKENIZER_CHOICES
    AT_LEAST: ClassVar[dict[str, int]] = {}
    """Floors above 1 of integer fields (each integer of a tuple), merged over the bases."""

    latent_dim: int = 64
    """Width D of the action embedding (and of each codebook entry)."""
    hidden: tuple[int, ...] = DEFAULT_HIDDEN
    """Hidden widths of the encoder MLP; the decoder mirrors them."""

    @property
    def name(self) -> str:
        """The registry name of this config's tokenizer."""
        return self.type


TOKENIZER_REGISTRY = ComponentRegistry("tokenizer", TokenizerConfig, "icil_paper.tokenizers")
"""Every action tokenizer by name: its config class (`configs`) and its model class (the
mapping, filled as `icil_paper.tokenizers.factory` imports the models)."""

register_tokenizer = TOKENIZER_REGISTRY.register
"""`@register_tokenizer("name")` above `@dataclass(frozen=True)` on a `TokenizerConfig`
subclass (optionally naming its model class: `@register_tokenizer("name", "Class")`)."""

register_tokenizer_model = TOKENIZER_REGISTRY.model
"""`@register_tokenizer_model("name")` on the `ActionTokenizer` built from config `name`."""


@dataclass(frozen=True)
class LipschitzOptions(Checked):
    """How every `LipschitzLinear` layer (Eq. 4) of an encoder is set up and regularised."""

    weight: float = 1e-6
    """gamma, the weight of L_Lipschitz = prod_l softplus(c_l) in the loss (Eq. 5)."""
    per_row: bool = False
    """One bound per output row (the official code) instead of one per layer (the paper)."""
    c_init: float | None = None
    """Initial c of every layer; None: the layer's largest absolute row sum (Liu et al.)."""
    weight_init: str = "liu"
    """`liu` (the paper's), `randn` (the official code) or `linear` (`nn.Linear`'s; presets)."""
    c_lr_scale: float = 1.0
    """Learning rate of every bound c_l as a multiple of the trainer's (0: fixed; 1: paper)."""

    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"weight_init": ("liu", "randn", "linear")}


@register_tokenizer("mlp")
@dataclass(frozen=True)
class MLPConfig(TokenizerConfig):
    """`mlp`: ICRT's continuous action MLP."""

    autoencode: bool = False
    """Let the reconstruction loss train the encoder too (stand-alone training)."""
    recon_weight: float = 1.0
    """Weight of the reconstruction loss."""


@register_tokenizer("lip-mlp")
@dataclass(frozen=True)
class LipMLPConfig(MLPConfig):
    """`lip-mlp`: the ICRT MLP with every linear layer Lipschitz-normalised (Table IV)."""

    lipschitz: LipschitzOptions = dataclasses.field(default_factory=LipschitzOptions)
    """The Lipschitz layers' initialisation and loss weight."""


@register_tokenizer("bin")
@dataclass(frozen=True)
class BinConfig(TokenizerConfig):
    """`bin`: RT-1 style uniform bins per action dimension."""

    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"range": ("fixed", "running")}
    AT_LEAST: ClassVar[dict[str, int]] = {"n_bins": 2}

    n_bins: int = 256
    """Uniform bins per action dimension (RT-1: 256; the official code: 20)."""
    range: str = "fixed"
    """Bin range per dimension: `fixed` (fitted, RT-1's) or `running` (the official code's)."""
    autoencode: bool = False
    """Let the decode head's loss train the bin embeddings (stand-alone training)."""
    decode_weight: float = 1.0
    """Weight of the decode head's loss."""


@register_tokenizer("fast")
@dataclass(frozen=True)
class FASTConfig(TokenizerConfig):
    """`fast`: DCT of action chunks, rounded, then byte-pair encoded (Pertsch et al. 2025)."""

    AT_LEAST: ClassVar[dict[str, int]] = {"vocab_size": 2}

    chunk: int = 8
    """Action steps per DCT chunk."""
    scale: float = 10.0
    """DCT coefficients are multiplied by this before rounding (FAST: 10)."""
    vocab_size: int = 1024
    """BPE vocabulary size (FAST: 1024)."""
    min_frequency: int = 2
    """BPE merge threshold (FAST: 2)."""
    mode: str = "causal"
    """`causal` (step t: the chunk ending at t) or `blocked` (FAST's chunks; not causal)."""
    autoencode: bool = False
    """Let the decode head's loss train the token embeddings (stand-alone training)."""
    decode_weight: float = 1.0
    """Weight of the decode head's loss."""


@dataclass(frozen=True)
class NormedEncoderConfig(TokenizerConfig):
    """Knobs of every learned quantizer's encoder (vq, fsq, rvq): its weight normalisation.

    `lipvq`, `lipfsq` and `liprvq` are `vq`, `fsq` and `rvq` with `norm="lipschitz"`."""

    norm: str = "none"
    """`none`, `lipschitz` (Eq. 4, every layer), `lipschitz-last` (official) or `spectral`."""
    lipschitz: LipschitzOptions = dataclasses.field(default_factory=LipschitzOptions)
    """The Lipschitz layers' initialisation and loss weight (with a Lipschitz norm)."""


@register_tokenizer("vq")
@dataclass(frozen=True)
class VQConfig(NormedEncoderConfig):
    """`vq`: VQ-VAE over single actions (van den Oord et al. 2017)."""

    AT_LEAST: ClassVar[dict[str, int]] = {"codebook_size": 2}

    codebook_size: int = 1024
    """K, the number of codebook entries (the paper: 2^10)."""
    codebook_weight: float = 1.0
    """alpha, the weight of the codebook loss ||sg[z_e] - z_q||^2."""
    commitment_weight: float = 0.25
    """beta, the weight of the commitment loss ||z_e - sg[z_q]||^2."""
    recon_weight: float = 1.0
    """Weight of the reconstruction loss."""
    straight_through: str = "vqvae"
    """Gradients past the quantizer: `vqvae` (to z_e), `codebook` (also the codes) or `none`
    (the encoder learns from the commitment loss only, the official code)."""
    detach_embeddings: bool = False
    """Give the policy sg[z_q] (the official code) instead of the straight-through value."""
    activation: str = "relu"
    """`relu` (the paper) or `gelu` (the official code)."""
    output_activation: str = "none"
    """After the encoder's last layer: `none` (the paper) or `sigmoid` (the official code)."""
    decoder_hidden: tuple[int, ...] | None = None
    """Decoder hidden widths; None mirrors `hidden`."""
    codebook_init: str = "uniform"
    """`uniform` (VQ-VAE's U(-1/K, 1/K)) or `data` (encoder outputs of the first batch)."""
    dead_code_restart: int = 0
    """Every this many steps, move unused codes to random encoder outputs; 0 never."""
    codebook_weight_decay: bool = True
    """Apply the optimiser's weight decay to the codebook (the paper's plain training)."""


@register_tokenizer("lfq")
@dataclass(frozen=True)
class LFQConfig(TokenizerConfig):
    """`lfq`: lookup-free quantization (MAGVIT-v2), the paper's LFQ-VAE."""

    codebook_size: int = 1024
    """K, a power of two; each code has log2(K) bits."""
    entropy_weight: float = 0.1
    """Weight of the entropy loss (MAGVIT-v2: 0.1)."""
    commitment_weight: float = 0.25
    """Weight of the commitment loss."""
    diversity_gamma: float = 1.0
    """Weight of the batch-entropy term inside the entropy loss."""
    recon_weight: float = 1.0
    """Weight of the reconstruction loss."""

    def __post_init__(self) -> None:
        super().__post_init__()
        k = self.codebook_size
        if k < 2 or k & (k - 1):
            raise ConfigError(f"LFQConfig.codebook_size must be a power of two >= 2 (each code "
                              f"is log2(K) bits), got {k}")


@register_tokenizer("lipvq")
@dataclass(frozen=True)
class LipVQConfig(VQConfig):
    """`lipvq`: LipVQ-VAE, a VQ-VAE with every encoder layer Lipschitz-normalised (the paper's)."""

    norm: str = "lipschitz"
    """Encoder weight normalisation (the paper: `lipschitz`, Eq. 4 on every layer)."""


# ----------------------------------------------------------------- training alone
@dataclass(frozen=True)
class TokenizerStudyConfig(Checked):
    """Tokenizers trained alone on action trajectories (chapters 02 and 04, the benchmark)."""

    CHOICES = {"trajectories": ("demos", "synthetic")}

    steps: int = 2000
    """Optimizer steps when a tokenizer is trained on its own."""
    batch_size: int = 64
    """Trajectory windows per batch."""
    window: int = 16
    """Steps per trajectory window."""
    lr: float = 1e-3
    """Adam learning rate."""
    trajectories: str = "demos"
    """`demos` (the preset's generated demonstrations) or `synthetic` (minimum-jerk)."""
    eval_fraction: float = 0.2
    """Share of each task's demonstrations held out for the metrics (at least one)."""
    n_trajectories: int = 200
    """`synthetic` only: generated trajectories a tokenizer is trained on."""
    n_eval_trajectories: int = 50
    """`synthetic` only: held-out generated trajectories the metrics are computed on."""
    trajectory_noise: float = 0.02
    """Amplitude of the low-pass noise added to generated trajectories (teleoperation tremor)."""
    bench_fast_actions: int = 1_000_000
    """Actions FAST's BPE is fitted on in the benchmark (the paper: 1M)."""
    seeds: int = 3
    """Training seeds of every tokenizer trained alone (the chapters show the spread)."""


def lipvq_official(latent_dim: int = 64, codebook_size: int = 1024) -> LipVQConfig:
    """The official code's LipVQ-VAE (the differences are listed in `lipvq.py`)."""
    return LipVQConfig(
        latent_dim=latent_dim, codebook_size=codebook_size, hidden=(64, 128),
        decoder_hidden=(64, 128), norm="lipschitz-last", activation="gelu",
        output_activation="sigmoid", straight_through="none", detach_embeddings=True,
        codebook_weight=0.25, commitment_weight=0.25,
        lipschitz=LipschitzOptions(weight=0.0, per_row=True, c_init=1.0, weight_init="randn"))


def official_bin(latent_dim: int = 64) -> BinConfig:
    """The official code's Bin: 20 bins over the running range of the training actions."""
    return BinConfig(latent_dim=latent_dim, n_bins=20, range="running")


# ----------------------------------------------------------------- since the paper
@register_tokenizer("fsq")
@dataclass(frozen=True)
class FSQConfig(NormedEncoderConfig):
    """`fsq`: finite scalar quantization (Mentzer et al. 2023) of one action per step."""

    AT_LEAST: ClassVar[dict[str, int]] = {"levels": 3}

    levels: tuple[int, ...] = (8, 5, 5, 5)
    """Levels of each code dimension (at least 3 each): prod(levels) codes."""
    recon_weight: float = 1.0
    """Weight of the reconstruction loss."""


@register_tokenizer("lipfsq")
@dataclass(frozen=True)
class LipFSQConfig(FSQConfig):
    """`lipfsq`: FSQ with every encoder layer Lipschitz-normalised (Eq. 4), as in LipVQ-VAE."""

    norm: str = "lipschitz"
    """Encoder weight normalisation (`lipschitz`: Eq. 4 on every layer, as LipVQ-VAE)."""


@register_tokenizer("rvq")
@dataclass(frozen=True)
class RVQConfig(NormedEncoderConfig):
    """`rvq`: residual vector quantization (VQ-BeT's tokenizer; Lee et al. 2024)."""

    AT_LEAST: ClassVar[dict[str, int]] = {"codebook_size": 2}

    num_quantizers: int = 2
    """Residual levels: each quantizes what the levels before it left (VQ-BeT: 2)."""
    codebook_size: int = 32
    """Codes per level (32 x 32 = 1024 combinations, the paper's K; VQ-BeT: 16)."""
    commitment_weight: float = 0.25
    """beta, the weight of the commitment loss summed over levels (codebooks learn by EMA)."""
    recon_weight: float = 1.0
    """Weight of the reconstruction loss."""


@register_tokenizer("liprvq")
@dataclass(frozen=True)
class LipRVQConfig(RVQConfig):
    """`liprvq`: residual VQ with every encoder layer Lipschitz-normalised (Eq. 4)."""

    norm: str = "lipschitz"
    """Encoder weight normalisation (`lipschitz`: Eq. 4 on every layer, as LipVQ-VAE)."""


@register_tokenizer("bspline")
@dataclass(frozen=True)
class BSplineConfig(TokenizerConfig):
    """`bspline`: BEAST (Zhou et al. 2025), quantized B-spline control points of chunks."""

    chunk: int = 8
    """Action steps per fitted chunk (step t is tokenized with the chunk ending at t)."""
    control_points: int = 5
    """K, control points per action dimension (4 <= K <= chunk)."""
    n_bins: int = 256
    """Integer bins of each control point's value over its fitted range (BEAST: 256)."""
    autoencode: bool = False
    """Let the decode head's loss train the token embeddings (stand-alone training)."""
    decode_weight: float = 1.0
    """Weight of the decode head's loss."""

    AT_LEAST: ClassVar[dict[str, int]] = {"control_points": 4, "n_bins": 2}

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.control_points > self.chunk:
            raise ConfigError(f"BSplineConfig.control_points ({self.control_points}) must be at "
                              f"most chunk ({self.chunk}): a clamped cubic B-spline fits no "
                              "more control points than the chunk has steps")


TOKENIZER_CONFIGS: dict[str, type[TokenizerConfig]] = TOKENIZER_REGISTRY.configs
"""Registry name -> config class: the paper's in Table I's order, then `SINCE_PAPER`."""

SINCE_PAPER = ("fsq", "lipfsq", "rvq", "liprvq", "bspline")
"""The tokenizers the paper does not compare: FSQ, residual VQ, BEAST and their Eq. 4 twins."""

default_config = TOKENIZER_REGISTRY.default
"""`default_config(name, **fields)`: the default config of tokenizer `name`, some fields changed."""
