"""Every action tokenizer of the paper behind one interface (see `base.py`).

    from icil_paper.tokenizers import make_tokenizer, TOKENIZERS
    from icil_paper.tokenizers.configs import LipVQConfig, lipvq_official
    tok = make_tokenizer(LipVQConfig(latent_dim=64), action_dim=7)   # as the paper writes it
    tok = make_tokenizer(lipvq_official(latent_dim=64), 7)          # the official code's variant
    tok = make_tokenizer("vq", 7)                                   # a name: its default config
    out = tok(actions)                                              # actions (B, T, 7)
    tok = load_tokenizer("exported/lipvq")       # a trained one, exported (`portable.py`)

Each tokenizer is built from its config alone (`configs.py`, one dataclass per tokenizer,
torch-free); `TOKENIZERS` lists the names, the paper's in its order, then the later ones.

| name      | file       | paper                          | discrete | fit needed |
|-----------|------------|--------------------------------|----------|------------|
| `mlp`     | mlp.py     | ICRT's action MLP              | no       | no         |
| `lip-mlp` | mlp.py     | MLP + Eq. 4 (Table IV)         | no       | no         |
| `bin`     | bin.py     | RT-1 uniform bins              | yes      | ranges     |
| `fast`    | fast.py    | FAST: DCT + BPE                | yes      | BPE vocab  |
| `vq`      | vq.py      | VQ-VAE                         | yes      | no         |
| `lfq`     | lfq.py     | LFQ-VAE (MAGVIT-v2)            | yes      | no         |
| `lipvq`   | lipvq.py   | LipVQ-VAE (Sec. III-B)         | yes      | no         |

And the tokenizers that came after the paper (`configs.SINCE_PAPER`), each learned one with
and without Eq. 4 (`lip*`: the same class, every encoder layer a LipschitzLinear):

| name      | file       | source                          | discrete | fit needed |
|-----------|------------|---------------------------------|----------|------------|
| `fsq`     | fsq.py     | FSQ (Mentzer et al. 2023)       | yes      | no         |
| `lipfsq`  | fsq.py     | FSQ + Eq. 4                     | yes      | no         |
| `rvq`     | rvq.py     | residual VQ (VQ-BeT, 2024)      | yes      | no         |
| `liprvq`  | rvq.py     | residual VQ + Eq. 4             | yes      | no         |
| `bspline` | bspline.py | B-spline control points (BEAST) | yes      | ranges     |

Tokenizer modules are imported on first use (a lazy registry), and so are the names of
this package that live in torch modules (`TORCH_NAMES`: `make_tokenizer`, `ActionTokenizer`,
`load_tokenizer`, ...): importing the package, or its torch-free `configs` (which the presets
and the command line read), imports neither torch, nor scipy, nor the `tokenizers` package.

A new tokenizer is one module: an `ActionTokenizer` subclass and its config, registered by
one decorator (nothing else to edit; the presets give it their shared sizes, `latent_dim`
and, where it has that field, `codebook_size`; `icil_paper.config` may add its own values):

    from dataclasses import dataclass
    from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, register_tokenizer

    @register_tokenizer("toy", "ToyTokenizer")      # the class below, imported on first use
    @dataclass(frozen=True)
    class ToyConfig(TokenizerConfig):
        scale: float = 1.0   # (with its docstring under it, as every config field)

    class ToyTokenizer(ActionTokenizer): ...

`--set tokenizers.toy.scale=2 --tokenizer toy` then works on the command line once the
module is imported (`tests/test_registration.py` runs one end to end). Outside the package
the module is a plugin: `--plugin FILE_OR_MODULE` on any command, or an entry point of the
group `icil_paper.tokenizers` that the registry loads on first use (`icil_paper.plugins`;
`icil-paper compare` reads it against LipVQ-VAE, chapter 14).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from icil_paper.tokenizers.configs import (
    TOKENIZER_CONFIGS,
    TOKENIZER_REGISTRY,
    TokenizerConfig,
    default_config,
    lipvq_official,
    register_tokenizer,
)

if TYPE_CHECKING:
    from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput, make_tokenizer
    from icil_paper.tokenizers.fast import FastDecodeError
    from icil_paper.tokenizers.lipschitz_linear import (
        LipschitzLinear,
        lipschitz_bounds,
        lipschitz_layers,
        lipschitz_loss,
    )
    from icil_paper.tokenizers.portable import (
        TokenizerFolderError,
        load_tokenizer,
        save_tokenizer,
    )

TOKENIZERS = tuple(TOKENIZER_CONFIGS)
"""The built-in tokenizers' names, the paper's in its order, then the later ones (a snapshot:
`REGISTRY` also holds those registered after this package was imported)."""

REGISTRY = TOKENIZER_REGISTRY
"""Name -> tokenizer class, imported on first use; filled by `register_tokenizer` on each
config class (`configs.py`)."""

TORCH_NAMES = {
    "ActionTokenizer": "base", "TokenizerOutput": "base", "make_tokenizer": "base",
    "LipschitzLinear": "lipschitz_linear", "lipschitz_loss": "lipschitz_linear",
    "lipschitz_bounds": "lipschitz_linear", "lipschitz_layers": "lipschitz_linear",
    "load_tokenizer": "portable", "save_tokenizer": "portable",
    "TokenizerFolderError": "portable", "FastDecodeError": "fast",
}
"""Name -> the module of this package it lives in, imported on first use (PEP 562), as the
registry imports the tokenizer classes: each of those modules imports torch."""


def __getattr__(name: str):
    if name not in TORCH_NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{TORCH_NAMES[name]}"), name)
    globals()[name] = value
    return value


__all__ = [
    "TOKENIZERS", "REGISTRY", "make_tokenizer", "ActionTokenizer", "TokenizerOutput",
    "TokenizerConfig", "default_config", "lipvq_official", "register_tokenizer",
    "LipschitzLinear", "lipschitz_loss", "lipschitz_bounds", "lipschitz_layers",
    "FastDecodeError", "load_tokenizer", "save_tokenizer", "TokenizerFolderError",
]
