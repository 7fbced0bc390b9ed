"""`bin`: RT-1 style discretization (Brohan et al. 2022), 256 uniform bins per action dimension.

`fit` records each action dimension's range [low_a, high_a] over the data. A value is then
mapped to one of `n_bins` equal bins of its dimension (values outside the fitted range go to
the first or last bin), and reconstructed at the bin's centre, so the reconstruction error
per dimension is at most half a bin width, (high_a - low_a) / (2 n_bins).

Every (dimension, bin) pair has its own learned embedding; a step's A tokens are pooled by
their mean into one embedding per step:

    actions (B, T, A) --bins--> codes (B, T, A) --table (A * n_bins, D), mean over A--> (B, T, D)

`reconstruction` is the bin centres (exact up to the bin width). `decode(embeddings)` is a
learned MLP head that maps a pooled embedding back to actions; it learns on detached
embeddings unless `autoencode=True` (then the table is trained by reconstruction too, as in
stand-alone training). In the policy, the table is trained by the policy's loss.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput
from icil_paper.tokenizers.configs import BinConfig


class BinTokenizer(ActionTokenizer):
    """Uniform per-dimension bins over fitted ranges, an embedding per (dimension, bin)."""

    name = "bin"
    discrete = True
    needs_fit = True

    def __init__(self, config: BinConfig, action_dim: int):
        super().__init__(config, action_dim)
        n_bins, latent_dim = config.n_bins, config.latent_dim
        if n_bins < 2:
            raise ValueError(f"n_bins must be at least 2, got {n_bins}")
        self.n_bins = int(n_bins)
        self.autoencode = config.autoencode
        self.decode_weight = config.decode_weight
        self.register_buffer("low", torch.full((action_dim,), -1.0))
        self.register_buffer("high", torch.full((action_dim,), 1.0))
        self.embedding = nn.Embedding(action_dim * n_bins, latent_dim)
        self.decoder = mlp([latent_dim, *config.hidden[::-1], action_dim])
        # Token id of bin b of dimension a is a * n_bins + b.
        self.register_buffer("offsets", torch.arange(action_dim) * n_bins, persistent=False)

    def _fit(self, trajectories: list[np.ndarray]) -> None:
        data = np.concatenate(trajectories, axis=0)
        low, high = data.min(axis=0), data.max(axis=0)
        # A constant dimension (e.g. an unused rotation axis) still gets a non-empty range.
        flat = high - low < 1e-6
        low[flat] -= 1e-3
        high[flat] += 1e-3
        self.low.copy_(torch.as_tensor(low))
        self.high.copy_(torch.as_tensor(high))

    @property
    def bin_width(self) -> Tensor:
        """(A,) width of one bin in each dimension."""
        return (self.high - self.low) / self.n_bins

    def bins(self, actions: Tensor) -> Tensor:
        """Bin index of every value: (B, T, A) -> LongTensor (B, T, A) in [0, n_bins)."""
        scaled = (actions - self.low) / self.bin_width
        return scaled.floor().long().clamp(0, self.n_bins - 1)

    def centres(self, codes: Tensor) -> Tensor:
        """Bin centres of codes (B, T, A) -> actions (B, T, A)."""
        return self.low + (codes.to(self.low.dtype) + 0.5) * self.bin_width

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        codes = self.bins(actions)  # (B, T, A)
        tokens = self.embedding(codes + self.offsets)  # (B, T, A, D)
        z = tokens.mean(dim=2)  # (B, T, D)
        decoded = self.decoder(z if self.autoencode else z.detach())
        losses = {"decode": self.decode_weight * F.mse_loss(decoded, actions)}
        return TokenizerOutput(embeddings=z, reconstruction=self.centres(codes), codes=codes,
                               losses=losses)

    def vocabulary_ids(self, codes: Tensor) -> Tensor:
        """Codes (B, T, A) as token ids in [0, A * n_bins), flattened."""
        return (codes + self.offsets).flatten()

    @property
    def codebook_size(self) -> int:
        """A * n_bins distinct tokens (one vocabulary per action dimension)."""
        return self.action_dim * self.n_bins

    def tokens_per_step(self, actions=None) -> float:
        """One token per action dimension."""
        return float(self.action_dim)
