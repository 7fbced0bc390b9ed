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

Each policy is built from its config (`configs.py`) and its tokenizer's config alone.
Importing this package imports no torch: `make_policy`, `build_policy` and `REGISTRY` load
the policy modules on first use.
"""

from __future__ import annotations

from icil_paper.policies.configs import (
    POLICY_CONFIGS,
    PolicyConfig,
    default_policy_config,
    register_policy,
    register_policy_model,
    resolve_tokenizer,
)

POLICIES = tuple(POLICY_CONFIGS)


def __getattr__(name: str):
    # PEP 562: the torch-backed names import the policy modules on first use
    if name in ("make_policy", "build_policy", "REGISTRY"):
        from icil_paper.policies import factory

        return getattr(factory, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["POLICIES", "REGISTRY", "PolicyConfig", "build_policy", "default_policy_config",
           "make_policy", "register_policy", "register_policy_model",
           "resolve_tokenizer"]
