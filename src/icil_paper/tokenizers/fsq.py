"""`fsq` and `lipfsq`: finite scalar quantization (Mentzer et al. 2023, "Finite Scalar
Quantization: VQ-VAE Made Simple"), with and without Eq. 4.

    actions (B, T, A) --encoder--> z_e (B, T, d), d = len(levels)
        --FSQ: bound each dimension i to (-1, 1) by tanh, round to one of L_i levels-->
        q on the grid (B, T, d), code = the mixed-radix number of the level indices
        --straight-through (round's gradient is the identity)--> (project to D) -->
        embeddings (B, T, D) --decoder--> x_hat

The quantizer is `vector_quantize_pytorch.FSQ` (pinned in requirements.txt), given the
encoder's output directly (`dim=len(levels)`, so it adds no projection of its own). The
grid of dimension i holds the L_i values (j - floor(L_i / 2)) / floor(L_i / 2),
j = 0 .. L_i - 1 (FSQ's `_scale_and_shift_inverse`): for odd L_i symmetric in [-1, 1], for
even L_i from -1 to 1 - 1 / floor(L_i / 2). There is no codebook to learn, so no codebook or
commitment loss: the loss is the reconstruction alone (plus Eq. 5's Lipschitz term for
`lipfsq`).

Code width: the grid point has d = len(levels) coordinates, usually fewer than the token
width D; it is then mapped to D by a learned linear projection (as `lfq` does), and the
projected point is both the embedding the policy consumes and what the decoder reads.

`lipfsq` is the same tokenizer with every encoder layer a `LipschitzLinear` (Eq. 4), built
by the same `base.build_encoder` as LipVQ-VAE's, and the same gamma prod_l softplus(c_l)
term (`base.lipschitz_losses`): the encoder up to the quantizer is then Lipschitz in the
infinity norm with constant at most prod_l softplus(c_l), and FSQ's bound
tanh(z) * (L - 1) / 2 / floor(L / 2) adds a factor of at most 1 + 1e-3 before rounding.

Deviations from the FSQ paper: one action per step is quantized (the paper quantizes image
patches); the encoder is this project's MLP (the paper's is a CNN / MaskGIT's); levels
below 3 are refused (vector-quantize-pytorch needs its `preserve_symmetry` option for 2,
which the FSQ paper does not use).
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import (
    ActionTokenizer,
    TokenizerOutput,
    build_encoder,
    lipschitz_losses,
)
from icil_paper.tokenizers.configs import FSQConfig, register_tokenizer_model


@register_tokenizer_model("fsq")
class FSQTokenizer(ActionTokenizer):
    """Finite scalar quantization of one action per step (FSQConfig; see the module
    docstring); `lipfsq` with a LipFSQConfig."""

    name = "fsq"
    discrete = True

    def __init__(self, config: FSQConfig, action_dim: int):
        super().__init__(config, action_dim)
        levels = tuple(int(level) for level in config.levels)
        if not levels or min(levels) < 3:
            raise ValueError(f"FSQ levels must be at least 3 each (one or more dimensions), got "
                             f"{config.levels}")
        from vector_quantize_pytorch import FSQ

        self.levels = levels
        d, latent_dim = len(levels), config.latent_dim
        self.encoder = build_encoder([action_dim, *config.hidden, d], config.norm,
                                     lipschitz=config.lipschitz)
        self.quantizer = FSQ(levels=list(levels), dim=d)
        self.project = nn.Identity() if d == latent_dim else nn.Linear(d, latent_dim)
        self.decoder = mlp([latent_dim, *config.hidden[::-1], action_dim])

    @property
    def codebook_size(self) -> int:
        """prod(levels): every grid point is a code."""
        return math.prod(self.levels)

    def grid_values(self, dim: int) -> Tensor:
        """The L values dimension `dim` of a quantized latent can take, ascending."""
        half = self.levels[dim] // 2
        return (torch.arange(self.levels[dim], dtype=torch.float32) - half) / half

    def quantize(self, z_e: Tensor) -> tuple[Tensor, Tensor]:
        """z_e (..., d) -> (grid point q (..., d), with the straight-through gradient;
        codes (...) LongTensor in [0, codebook_size))."""
        q, codes = self.quantizer(z_e)
        return q, codes.long()

    def codes_to_grid(self, codes: Tensor) -> Tensor:
        """Codes (...) -> their grid points (..., d) (the inverse of `grid_to_codes`)."""
        return self.quantizer.indices_to_codes(codes)

    def grid_to_codes(self, grid: Tensor) -> Tensor:
        """Grid points (..., d) -> codes (...) LongTensor."""
        return self.quantizer.codes_to_indices(grid).long()

    def embed_codes(self, codes: Tensor) -> Tensor:
        """Codes (B, T) -> the embeddings (B, T, D) the policy consumes."""
        return self.project(self.codes_to_grid(codes).to(self._param_dtype()))

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z_e = self.encoder(actions)  # (B, T, d)
        q, codes = self.quantize(z_e)  # (B, T, d) on the grid, (B, T)
        z = self.project(q)  # (B, T, D)
        recon = self.decoder(z)  # (B, T, A)
        losses = {"reconstruction": self.config.recon_weight * F.mse_loss(recon, actions)}
        losses.update(lipschitz_losses(self.encoder, self.config))
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=codes, losses=losses,
                               latents=z_e)


@register_tokenizer_model("lipfsq")
class LipFSQTokenizer(FSQTokenizer):
    """`lipfsq`: FSQ whose encoder is Lipschitz-constrained by Eq. 4 (as LipVQ-VAE's)."""

    name = "lipfsq"
