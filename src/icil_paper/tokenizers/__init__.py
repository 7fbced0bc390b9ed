"""Every action tokenizer of the paper behind one interface (see `base.py`).

    from icil_paper.tokenizers import make_tokenizer, TOKENIZERS
    from icil_paper.tokenizers.configs import LipVQConfig, lipvq_official
    tok = make_tokenizer(LipVQConfig(latent_dim=64), action_dim=7)   # as the paper writes it
    tok = make_tokenizer(lipvq_official(latent_dim=64), 7)          # the official code's variant
    tok = make_tokenizer("vq", 7)                                   # a name: its default config
    out = tok(actions)                                              # actions (B, T, 7)
    tok = load_tokenizer("exported/lipvq")       # a trained one, exported (`portable.py`)

Each tokenizer is built from its config alone (`configs.py`, torch-free). `TOKENIZERS`
lists the names: the paper's in its order, then `configs.SINCE_PAPER`. Importing the package
imports no torch: the names of its torch modules load on first use.

A new tokenizer is one module: an `ActionTokenizer` subclass and its config, registered by
`@register_tokenizer("toy", "ToyTokenizer")` above `@dataclass(frozen=True)` on a
`TokenizerConfig` subclass; outside the package it is a plugin (`icil_paper.plugins`).
"""

from __future__ import annotations

from icil_paper.tokenizers.configs import (
    TOKENIZER_CONFIGS,
    TokenizerConfig,
    default_config,
    lipvq_official,
    register_tokenizer,
    register_tokenizer_model,
)

TOKENIZERS = tuple(TOKENIZER_CONFIGS)
"""The built-in tokenizers' names (`REGISTRY` also holds those registered later)."""


TORCH_NAMES = frozenset({
    "REGISTRY", "make_tokenizer", "ActionTokenizer", "TokenizerOutput", "LipschitzLinear",
    "lipschitz_loss", "lipschitz_bounds", "lipschitz_layers", "load_tokenizer",
    "save_tokenizer", "TokenizerFolderError", "FastDecodeError"})
"""The names of this package that live in its torch modules (`__getattr__`)."""


def __getattr__(name: str):
    # PEP 562: the names of torch modules, imported on first use
    if name not in TORCH_NAMES:  # (the submodules themselves too, while they import)
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from icil_paper.tokenizers import base, factory, fast, lipschitz_linear, portable

    for module in (factory, base, lipschitz_linear, portable, fast):
        if name in vars(module):
            return vars(module)[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["TOKENIZERS", "TokenizerConfig", "default_config", "lipvq_official",
           "register_tokenizer", "register_tokenizer_model", *sorted(TORCH_NAMES)]
