"""One config dataclass per policy; `make_policy(config, obs_spec, action_dim, tokenizer)` builds from it.

Torch-free, so that presets, the command line and result keys hold policy configs without
importing the models. `@register_policy(name)` registers a config class and sets its `type`;
the model class registers with `@register_policy_model(name)`.

    from icil_paper.policies import make_policy
    from icil_paper.policies.configs import ICRTConfig
    from icil_paper.tokenizers.configs import LipVQConfig
    policy = make_policy(ICRTConfig(d_model=64), obs_spec, 7, LipVQConfig(latent_dim=32))
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from icil_paper.config_data import Checked, ConfigError
from icil_paper.registry import ComponentRegistry, check_name
from icil_paper.tokenizers.configs import default_config

PROMPT_FROM = ("same_task", "minibatch")
"""The choices of `ICRTConfig.prompt_from`."""


@dataclass(frozen=True)
class PolicyConfig(Checked):
    """Sizes every policy shares: the transformer and the observation backbone."""

    type: ClassVar[str] = ""
    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"query_start": ("random", "episode_start")}
    takes_tokenizer: ClassVar[bool] = False
    """The policy embeds actions with any registered action tokenizer."""
    default_tokenizer: ClassVar[str | None] = None
    """The tokenizer it gets when none is given (None: it works without one)."""
    needs_images: ClassVar[bool] = False
    """It needs image observations (`data.obs` rgb or rgbd)."""

    d_model: int = 128
    """Token width."""
    n_layer: int = 4
    """Transformer layers."""
    n_head: int = 4
    """Attention heads."""
    dropout: float = 0.1
    """Dropout inside the transformer."""
    resnet_width: int = 64
    """First-stage channels of the ResNet-18 image backbone (torchvision's is 64)."""
    language: bool = False
    """Add a bag-of-words instruction embedding to every observation token (CLIP's stand-in)."""

    def __post_init__(self) -> None:
        super().__post_init__()  # ranges, empty values, CHOICES: before any work
        if self.d_model % self.n_head:
            raise ConfigError(f"{type(self).__name__}.d_model ({self.d_model}) must be a "
                              f"multiple of n_head ({self.n_head}): each attention head gets "
                              "d_model / n_head channels")

    @property
    def name(self) -> str:
        """The registry name of this config's policy."""
        return self.type

    def check_episode_length(self, longest: int) -> None:
        """Refuse (ConfigError) a config that cannot train on episodes of `longest` steps."""


POLICY_REGISTRY = ComponentRegistry("policy", PolicyConfig, "icil_paper.policies")
"""Every policy by name: its config class (`configs`) and its model class (the mapping,
filled as `icil_paper.policies.factory` imports the models)."""

register_policy = POLICY_REGISTRY.register
"""`@register_policy("name")` above `@dataclass(frozen=True)` on a `PolicyConfig` subclass."""

register_policy_model = POLICY_REGISTRY.model
"""`@register_policy_model("name")` on the `Policy` built from config `name`."""


@register_policy("icrt")
@dataclass(frozen=True)
class ICRTConfig(PolicyConfig):
    """ICRT (Sec. III-A): a causal transformer over prompt demonstrations and the query."""

    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"prompt_from": PROMPT_FROM}
    takes_tokenizer: ClassVar[bool] = True
    default_tokenizer: ClassVar[str | None] = "mlp"

    chunk_size: int = 4
    """Future actions predicted per query step (action chunking; the first is executed)."""
    prompt_demos: int = 1
    """Full demonstrations in a prompt (the paper uses one)."""
    max_seq_len: int = 1024
    """Longest token sequence trained on and kept in the KV cache (the prompt always stays)."""
    query_actions: bool = True
    """Interleave the query's past actions with its observations (ICRT's code; False: Eq. 1)."""
    query_len: int = 0
    """Query steps per training sequence; 0: whole episodes (which must fit in max_seq_len)."""
    query_start: str = "episode_start"
    """Where a training query window starts: `episode_start` (step 0) or `random` (ICRT's)."""
    prompt_from: str = "same_task"
    """Prompts from the query's task, `same_task` (the paper), or `minibatch` (official code)."""

    def sequence_tokens(self, longest: int) -> int:
        """Tokens of the longest training sequence on episodes of up to `longest` steps."""
        query = longest if self.query_len == 0 else min(self.query_len, longest)
        return 2 * self.prompt_demos * longest + (2 if self.query_actions else 1) * query

    def check_episode_length(self, longest: int) -> None:
        n = self.sequence_tokens(longest)
        if n > self.max_seq_len:
            window = ("whole episodes (query_len=0)" if self.query_len == 0
                      else f"query windows of {self.query_len} steps")
            raise ConfigError(
                f"ICRTConfig.max_seq_len={self.max_seq_len} is below the {n} tokens of a "
                f"training sequence on these demonstrations ({self.prompt_demos} prompt "
                f"episode(s) and {window}, episodes of up to {longest} steps): raise "
                f"policies.icrt.max_seq_len to at least {n}, or train on shorter query windows "
                "(policies.icrt.query_len)")


@register_policy("bc_transformer")
@dataclass(frozen=True)
class BCTransformerConfig(PolicyConfig):
    """robomimic's BC-Transformer: a transformer over an observation history, no prompt."""

    history: int = 10
    """Observation steps in the context (robomimic's context length)."""


@register_policy("act")
@dataclass(frozen=True)
class ACTConfig(PolicyConfig):
    """ACT (Zhao et al. 2023) at BC-Transformer's size; with a tokenizer, Table II's ACT + rows."""

    takes_tokenizer: ClassVar[bool] = True

    chunk_size: int = 4
    """Actions predicted per chunk."""
    latent_dim: int = 32
    """Width of the CVAE's latent z (plain ACT)."""
    kl_weight: float = 10.0
    """Weight of the KL term of the CVAE loss."""
    ensemble_m: float = 0.01
    """Temporal ensembling weights exp(-m i) over overlapping chunks."""


@register_policy("mcr")
@dataclass(frozen=True)
class MCRConfig(PolicyConfig):
    """MCR (Jiang et al. 2025): a manipulation-centric visual encoder, frozen under a BC head."""

    needs_images: ClassVar[bool] = True

    chunk_size: int = 4
    """Actions predicted per step by the BC head (the first is executed)."""
    pretrain_steps: int = 1000
    """Steps of manipulation-centric pre-training of the visual encoder before it is frozen."""
    pretrain_batch: int = 16
    """Batch size of the pre-training."""
    pretrain_lr: float = 3e-4
    """Learning rate of the pre-training."""


POLICY_CONFIGS: dict[str, type[PolicyConfig]] = POLICY_REGISTRY.configs
"""Registry name -> config class, in registration order."""

default_policy_config = POLICY_REGISTRY.default
"""`default_policy_config(name, **fields)`: the default config of policy `name`, some changed."""


def resolve_tokenizer(policy: str, tokenizer: Any, latent_dim: int | None = None):
    """The tokenizer config a policy gets: `tokenizer` (a config or a name), else the
    policy's default (or None). ValueError when the policy does not take that tokenizer."""
    cls = POLICY_CONFIGS[check_name("policy", policy, POLICY_CONFIGS)]
    if tokenizer is None:
        if cls.default_tokenizer is None:
            return None
        fields = {"latent_dim": latent_dim} if latent_dim else {}
        return default_config(cls.default_tokenizer, **fields)
    if isinstance(tokenizer, str):
        tokenizer = default_config(tokenizer)
    if not cls.takes_tokenizer:
        raise ValueError(f"the {policy} policy does not take the {tokenizer.type!r} action "
                         "tokenizer (it takes none)")
    return tokenizer
