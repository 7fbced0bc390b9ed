"""ICRT and the baselines of Tables I and II, behind one interface (`base.Policy`).

    from icil_paper.policies import make_policy, POLICIES
    policy = make_policy("icrt", obs_dim=19, action_dim=7, config=preset.policy, tokenizer="lipvq")

| name             | file               | paper                                         | tokenizer            |
|------------------|--------------------|-----------------------------------------------|----------------------|
| `icrt`           | icrt.py            | ICRT, Sec. III-A (Table I's ICRT rows)        | any (default `mlp`)  |
| `bc_transformer` | bc_transformer.py  | robomimic BC-Transformer (Tables I, II)       | none                 |
| `act`            | act.py             | ACT (Table II); with a tokenizer: ACT+tok rows| none = CVAE, or any  |
| `mcr`            | mcr.py             | MCR encoder + BC head (images only)           | none                 |

`obs_dim` is the width of proprio and object state concatenated, or a mapping of keys to
shapes (`{"proprio": 9, "object": 10, "rgb": (2, 84, 84, 3)}`), or an `ObsSpec`. Policy
modules are imported on first use (a lazy registry).
"""

from __future__ import annotations

from typing import Any

from icil_paper.registry import Registry

POLICIES = ("icrt", "bc_transformer", "act", "mcr")

REGISTRY = Registry("policy", {
    "icrt": "icil_paper.policies.icrt:ICRT",
    "bc_transformer": "icil_paper.policies.bc_transformer:BCTransformer",
    "act": "icil_paper.policies.act:ACT",
    "mcr": "icil_paper.policies.mcr:MCR",
})

# Which tokenizers each policy takes (None = no tokenizer).
TAKES_TOKENIZER = {"icrt": True, "bc_transformer": False, "act": True, "mcr": False}


def make_policy(name: str, obs_dim: Any, action_dim: int, config: Any,
                tokenizer: str | None = None, **options: Any):
    """Build the policy called `name` (one of POLICIES).

    `tokenizer` names an action tokenizer (`icil_paper.tokenizers.TOKENIZERS`) for `icrt`
    (default `mlp`) and `act` (None = ACT's own CVAE encoder); `bc_transformer` and `mcr`
    take none and raise ValueError if given one. Unknown names raise UnknownNameError.
    """
    cls = REGISTRY[name]
    if tokenizer is not None:
        from icil_paper.registry import check_name
        from icil_paper.tokenizers import TOKENIZERS

        check_name("tokenizer", tokenizer, TOKENIZERS)
        if not TAKES_TOKENIZER[name]:
            raise ValueError(f"the {name} policy takes no action tokenizer (got {tokenizer!r})")
    return cls(obs_dim, action_dim, config, tokenizer=tokenizer, **options)


def policy_label(name: str, tokenizer: str | None) -> str:
    """A run's display name: `icrt+lipvq`, `act`, `act+bin`, `bc_transformer`."""
    if name == "icrt" and tokenizer is None:
        tokenizer = "mlp"
    return f"{name}+{tokenizer}" if tokenizer else name


__all__ = ["POLICIES", "REGISTRY", "TAKES_TOKENIZER", "make_policy", "policy_label"]
