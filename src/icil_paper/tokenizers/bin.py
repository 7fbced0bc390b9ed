"""`bin`: RT-1 style discretization (Brohan et al. 2022), 256 uniform bins per action dimension.

`fit` records each action dimension's range [low_a, high_a]. A value goes to one of `n_bins`
equal bins of its dimension (clipped to the first or last) and is reconstructed at the bin's
centre: the error per dimension is at most (high_a - low_a) / (2 n_bins). The official code's
variant (`configs.official_bin()`, `range="running"`) fits nothing: each training batch
widens the range (from [-1, 1] until the first), kept in buffers for evaluation.

Every (dimension, bin) pair has its own learned embedding, mean-pooled per step:

    actions (B, T, A) --bins--> codes (B, T, A) --table (A * n_bins, D), mean over A--> (B, T, D)

`decode(embeddings)` is a learned MLP head (on detached embeddings unless `autoencode=True`).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.config_data import field_choices
from icil_paper.layers import mlp
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput
from icil_paper.tokenizers.configs import BinConfig, register_tokenizer_model

RANGES = field_choices(BinConfig)["range"]
"""`fixed` (fitted before training) or `running` (widened by every training batch)."""


@register_tokenizer_model("bin")
class BinTokenizer(ActionTokenizer):
    """Uniform per-dimension bins over fitted (or running) ranges (BinConfig)."""

    name = "bin"
    discrete = True
    needs_fit = True

    def __init__(self, config: BinConfig, action_dim: int):
        super().__init__(config, action_dim)
        n_bins, latent_dim = config.n_bins, config.latent_dim
        self.n_bins = int(n_bins)
        self.range = config.range
        self.register_buffer("low", torch.full((action_dim,), -1.0))
        self.register_buffer("high", torch.full((action_dim,), 1.0))
        if self.range == "running":
            self.needs_fit = False  # the range comes from the training batches
            self._fitted.fill_(True)
            # Whether a training batch has set the range yet (saved with the tokenizer).
            self.register_buffer("_range_seen", torch.tensor(False))
        self.embedding = nn.Embedding(action_dim * n_bins, latent_dim)
        self.decoder = mlp([latent_dim, *config.hidden[::-1], action_dim])
        # Token id of bin b of dimension a is a * n_bins + b.
        self.register_buffer("offsets", torch.arange(action_dim) * n_bins, persistent=False)

    def _fit(self, trajectories: list[np.ndarray]) -> None:
        if self.range == "running":
            return  # nothing is fitted: training batches set the range
        data = np.concatenate(trajectories, axis=0)
        self._set_range(torch.as_tensor(data.min(axis=0)), torch.as_tensor(data.max(axis=0)))

    @torch.no_grad()
    def _update_running_range(self, actions: Tensor) -> None:
        """`range="running"`: widen [low, high] to the min and max of `actions` (B, T, A)."""
        flat = actions.reshape(-1, self.action_dim)
        low, high = flat.min(dim=0).values, flat.max(dim=0).values
        if bool(self._range_seen):
            low, high = torch.minimum(self.low, low), torch.maximum(self.high, high)
        self._set_range(low, high)
        self._range_seen.fill_(True)

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
        if self.range == "running" and self.training:
            self._update_running_range(actions)
        codes = self.bins(actions)  # (B, T, A)
        tokens = self.embedding(codes + self.offsets)  # (B, T, A, D)
        z = tokens.mean(dim=2)  # (B, T, D)
        return TokenizerOutput(embeddings=z, reconstruction=self.centres(codes), codes=codes,
                               losses=self.decode_losses(z, actions))

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
