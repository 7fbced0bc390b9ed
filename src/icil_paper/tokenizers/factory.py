"""Every tokenizer of the package by name, and `make_tokenizer`, which builds one from its config
(usage: the package's docstring). Importing it imports the tokenizer modules, which register."""

from __future__ import annotations

from icil_paper import plugins
from icil_paper.tokenizers import (  # noqa: F401 (each registers its classes)
    bin,
    bspline,
    fast,
    fsq,
    lfq,
    lipvq,
    mlp,
    rvq,
    vq,
)
from icil_paper.tokenizers.base import ActionTokenizer
from icil_paper.tokenizers.configs import TOKENIZER_REGISTRY, TokenizerConfig, default_config

REGISTRY = TOKENIZER_REGISTRY
"""Name -> tokenizer class (and `REGISTRY.configs`: name -> config class)."""


def make_tokenizer(config: TokenizerConfig | str, action_dim: int) -> ActionTokenizer:
    """Build the tokenizer a config describes (a name gives that tokenizer's default config);
    an unknown name raises UnknownNameError (a ValueError)."""
    plugins.discover()
    if isinstance(config, str):
        config = default_config(config)
    if not isinstance(config, TokenizerConfig) or not config.type:
        raise TypeError(f"make_tokenizer needs a tokenizer config (icil_paper.tokenizers.configs)"
                        f" or a name, got {type(config).__name__}")
    return REGISTRY[config.type](config, action_dim)
