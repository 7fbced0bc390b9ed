"""`fsq` and `lipfsq`: finite scalar quantization (Mentzer et al. 2023), with and without Eq. 4.

    actions (B, T, A) --encoder--> z_e (B, T, d), d = len(levels)
        --FSQ: bound each dimension i to (-1, 1) by tanh, round to one of L_i levels-->
        q on the grid (B, T, d), code = the mixed-radix number of the level indices
        --straight-through (round's gradient is the identity)--> (project to D) -->
        embeddings (B, T, D) --decoder--> x_hat

The quantizer is `vector_quantize_pytorch.FSQ` (`dim=len(levels)`). Dimension i's grid holds
the L_i values (j - floor(L_i / 2)) / floor(L_i / 2), j = 0 .. L_i - 1. The loss is the
reconstruction alone (plus Eq. 5's Lipschitz term for `lipfsq`, whose encoder layers are all
`LipschitzLinear`). A learned linear projection maps the grid point to D, as in `lfq`.

Deviations from the FSQ paper: one action per step is quantized (not image patches); levels
below 3 are refused.
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
    """Finite scalar quantization of one action per step (FSQConfig; `lipfsq`: LipFSQConfig)."""

    name = "fsq"
    discrete = True

    def __init__(self, config: FSQConfig, action_dim: int):
        super().__init__(config, action_dim)
        levels = tuple(int(level) for level in config.levels)
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
