"""Every action tokenizer of the paper behind one interface (see `base.py`).

    from icil_paper.tokenizers import make_tokenizer, TOKENIZERS
    tok = make_tokenizer("lipvq", action_dim=7, latent_dim=64)            # as the paper writes it
    tok = make_tokenizer("lipvq", 7, 64, variant="official")               # the official code's variant
    out = tok(actions)                                                    # actions (B, T, 7)

| name      | file       | paper                          | discrete | fit needed |
|-----------|------------|--------------------------------|----------|------------|
| `mlp`     | mlp.py     | ICRT's action MLP              | no       | no         |
| `lip-mlp` | mlp.py     | MLP + Eq. 5 (Table IV)         | no       | no         |
| `bin`     | bin.py     | RT-1 uniform bins              | yes      | ranges     |
| `fast`    | fast.py    | FAST: DCT + BPE                | yes      | BPE vocab  |
| `vq`      | vq.py      | VQ-VAE                         | yes      | no         |
| `lfq`     | lfq.py     | LFQ-VAE (MAGVIT-v2)            | yes      | no         |
| `lipvq`   | lipvq.py   | LipVQ-VAE (Sec. III-B)         | yes      | no         |

Tokenizer modules are imported on first use (a lazy registry), so importing this package
does not import scipy or the `tokenizers` package.
"""

from __future__ import annotations

from icil_paper.registry import Registry
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput
from icil_paper.tokenizers.lipschitz_linear import (
    LipschitzLinear,
    lipschitz_bounds,
    lipschitz_layers,
    lipschitz_loss,
)

TOKENIZERS = ("mlp", "lip-mlp", "bin", "fast", "vq", "lfq", "lipvq")

REGISTRY = Registry("tokenizer", {
    "mlp": "icil_paper.tokenizers.mlp:MLPTokenizer",
    "lip-mlp": "icil_paper.tokenizers.mlp:LipMLPTokenizer",
    "bin": "icil_paper.tokenizers.bin:BinTokenizer",
    "fast": "icil_paper.tokenizers.fast:FASTTokenizer",
    "vq": "icil_paper.tokenizers.vq:VQTokenizer",
    "lfq": "icil_paper.tokenizers.lfq:LFQTokenizer",
    "lipvq": "icil_paper.tokenizers.lipvq:LipVQTokenizer",
})


def make_tokenizer(name: str, action_dim: int, latent_dim: int, **options) -> ActionTokenizer:
    """Build the tokenizer called `name` (one of TOKENIZERS); options go to its constructor.

    An unknown name raises UnknownNameError (a ValueError) that lists the valid names.
    """
    return REGISTRY[name](action_dim, latent_dim, **options)


def __getattr__(name: str):
    # FastDecodeError lives in fast.py; importing it lazily keeps scipy/tokenizers unloaded.
    if name == "FastDecodeError":
        from icil_paper.tokenizers.fast import FastDecodeError

        return FastDecodeError
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "TOKENIZERS", "REGISTRY", "make_tokenizer", "ActionTokenizer", "TokenizerOutput",
    "LipschitzLinear", "lipschitz_loss", "lipschitz_bounds", "lipschitz_layers",
    "FastDecodeError",
]
