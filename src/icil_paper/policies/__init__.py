"""ICRT and the baselines of Tables I and II, behind one interface (`base.Policy`).

    from icil_paper.policies import make_policy
    policy = make_policy("icrt", obs_spec, action_dim=7, tokenizer="lipvq")   # default configs
    policy = make_policy(preset.policies.icrt, obs_spec, 7, preset.tokenizers.lipvq)

| name             | file               | paper                                         | tokenizers           |
|------------------|--------------------|-----------------------------------------------|----------------------|
| `icrt`           | icrt.py            | ICRT, Sec. III-A (Table I's ICRT rows)        | any (default `mlp`)  |
| `bc_transformer` | bc_transformer.py  | robomimic BC-Transformer (Tables I, II)       | none                 |
| `act`            | act.py             | ACT (Table II); with a tokenizer: ACT+tok rows| none = CVAE, or any  |
| `mcr`            | mcr.py             | MCR encoder + BC head (images only)           | none                 |

Each policy is built from its config (`configs.py`) and its tokenizer's config alone;
`obs_dim` is the width of proprio and object state concatenated, or a mapping of keys to
shapes (`{"proprio": 9, "object": 10, "rgb": (2, 84, 84, 3)}`), or an `ObsSpec`. Policy
modules are imported on first use (a lazy registry).
"""

from __future__ import annotations

from typing import Any

from icil_paper.policies.configs import (
    POLICY_CONFIGS,
    POLICY_REGISTRY,
    PolicyConfig,
    default_policy_config,
    register_policy,
)
from icil_paper.tokenizers.configs import default_config

POLICIES = tuple(POLICY_CONFIGS)

REGISTRY = POLICY_REGISTRY
"""Name -> policy class, imported on first use; filled by `register_policy` on each config
class (`configs.py`)."""


def resolve_tokenizer(policy: str, tokenizer: Any, latent_dim: int | None = None):
    """The tokenizer config a policy gets: `tokenizer` (a config or a name), else the
    policy's default (None for a policy that works without one). Raises ValueError when the
    policy does not take that tokenizer, naming the ones it takes."""
    cls = REGISTRY[policy]
    if tokenizer is None:
        if cls.default_tokenizer is None:
            return None
        fields = {"latent_dim": latent_dim} if latent_dim else {}
        return default_config(cls.default_tokenizer, **fields)
    if isinstance(tokenizer, str):
        tokenizer = default_config(tokenizer)
    if tokenizer.type not in cls.tokenizers:
        takes = (f"it takes {', '.join(cls.tokenizers)}" if cls.tokenizers
                 else "it takes none")
        raise ValueError(f"the {policy} policy does not take the {tokenizer.type!r} action "
                         f"tokenizer ({takes})")
    return tokenizer


def make_policy(config: PolicyConfig | str, obs_dim: Any, action_dim: int,
                tokenizer: Any = None):
    """Build the policy a config describes (a name gives its default config).

    `tokenizer`: a tokenizer config (`icil_paper.tokenizers.configs`) or name, for the
    policies that take one; None gives the policy's default (`mlp` for ICRT, the CVAE for
    ACT). Unknown names raise UnknownNameError; a tokenizer the policy does not take raises
    ValueError.
    """
    if isinstance(config, str):
        config = default_policy_config(config)
    tokenizer = resolve_tokenizer(config.type, tokenizer, latent_dim=config.d_model)
    return REGISTRY[config.type](config, obs_dim, action_dim, tokenizer)


def policy_label(policy: str, tokenizer: str | None) -> str:
    """A run's display name: `icrt+lipvq`, `act`, `act+bin`, `bc_transformer`."""
    default = REGISTRY[policy].default_tokenizer if policy in REGISTRY else None
    tokenizer = tokenizer or default
    return f"{policy}+{tokenizer}" if tokenizer else policy


__all__ = ["POLICIES", "REGISTRY", "make_policy", "register_policy", "policy_label", "resolve_tokenizer"]
