"""Every policy of the package by name, and the functions that build one from its config.

    from icil_paper.policies import make_policy, build_policy
    policy = make_policy("icrt", obs_spec, action_dim=7, tokenizer="lipvq")   # default configs
    policy = make_policy(preset.policies.icrt, obs_spec, 7, preset.tokenizers.lipvq)
    copy = build_policy(policy.spec)       # an untrained copy (saved policies, rollout workers)

Importing this module imports the policy modules (torch), whose classes register as they import.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from icil_paper import plugins
from icil_paper.config_data import from_dict
from icil_paper.policies import act, bc_transformer, icrt, mcr  # noqa: F401 (each registers its class)
from icil_paper.policies.base import Policy
from icil_paper.policies.batching import ObsSpec
from icil_paper.policies.configs import (
    POLICY_REGISTRY,
    PolicyConfig,
    default_policy_config,
    resolve_tokenizer,
)
from icil_paper.tokenizers.configs import TokenizerConfig

REGISTRY = POLICY_REGISTRY
"""Name -> policy class (and `REGISTRY.configs`: name -> config class)."""


def make_policy(config: PolicyConfig | str, obs_dim: Any, action_dim: int,
                tokenizer: Any = None) -> Policy:
    """Build the policy a config describes (a name gives its default config).

    `tokenizer`: a tokenizer config or name; None gives the policy's default (`mlp` for ICRT,
    the CVAE for ACT). Unknown names raise UnknownNameError (a ValueError).
    """
    plugins.discover()
    if isinstance(config, str):
        config = default_policy_config(config)
    tokenizer = resolve_tokenizer(config.type, tokenizer, latent_dim=config.d_model)
    return REGISTRY[config.type](config, obs_dim, action_dim, tokenizer)


def build_policy(spec: Mapping[str, Any]) -> Policy:
    """Rebuild an (untrained) policy from `policy.spec`."""
    tokenizer = spec.get("tokenizer")
    return make_policy(from_dict(PolicyConfig, spec["policy"]),
                       from_dict(ObsSpec, spec["obs_spec"]), int(spec["action_dim"]),
                       from_dict(TokenizerConfig, tokenizer) if tokenizer else None)
