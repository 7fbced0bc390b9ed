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

Importing the package, or its torch-free `configs` (which the presets and the command line
read), imports no torch: the names that live in torch modules (`make_tokenizer`,
`ActionTokenizer`, `load_tokenizer`, `REGISTRY`, ...) load on first use (`__getattr__`).

A new tokenizer is one module: an `ActionTokenizer` subclass and its config, registered by
one decorator (the presets give it their shared sizes, `latent_dim` and, where it has that
field, `codebook_size`; `icil_paper.config` may add its own values):

    from dataclasses import dataclass
    from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, register_tokenizer

    @register_tokenizer("toy", "ToyTokenizer")      # the class below, looked up on first use
    @dataclass(frozen=True)
    class ToyConfig(TokenizerConfig):
        scale: float = 1.0   # (with its docstring under it, as every config field)

    class ToyTokenizer(ActionTokenizer): ...

(The package's own tokenizers keep their configs in `configs.py` and register their classes
with `@register_tokenizer_model(name)`, imported by `factory.py`.)

`--set tokenizers.toy.scale=2 --tokenizer toy` then works on the command line once the
module is imported (`tests/test_registration.py` runs one end to end). Outside the package
the module is a plugin: `--plugin FILE_OR_MODULE` on any command, or an entry point of the
group `icil_paper.tokenizers`, loaded when a preset or a tokenizer is first built
(`icil_paper.plugins`;
`icil-paper compare` reads it against LipVQ-VAE, chapter 14).
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
"""The built-in tokenizers' names, the paper's in its order, then the later ones (a snapshot:
`REGISTRY` also holds those registered after this package was imported)."""


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


__all__ = [
    "TOKENIZERS", "REGISTRY", "make_tokenizer", "ActionTokenizer", "TokenizerOutput",
    "TokenizerConfig", "default_config", "lipvq_official", "register_tokenizer",
    "register_tokenizer_model", "LipschitzLinear", "lipschitz_loss", "lipschitz_bounds",
    "lipschitz_layers", "FastDecodeError", "load_tokenizer", "save_tokenizer",
    "TokenizerFolderError",
]
