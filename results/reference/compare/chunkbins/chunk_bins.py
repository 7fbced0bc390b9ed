"""`chunkbins`: uniform bins over chunks of actions, a tokenizer of one file."""

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, TokenizerOutput
from icil_paper.tokenizers import register_tokenizer


@register_tokenizer("chunkbins", "ChunkBinsTokenizer")
@dataclass(frozen=True)
class ChunkBinsConfig(TokenizerConfig):
    """`chunkbins`: each step embeds the uniform bins of its last `chunk` actions."""

    n_bins: int = 32
    """Uniform bins per action dimension over [-1, 1]."""
    chunk: int = 4
    """Actions per chunk: the step's own and the `chunk - 1` before it."""


class ChunkBinsTokenizer(ActionTokenizer):
    name = "chunkbins"
    discrete = True

    def __init__(self, config, action_dim):
        super().__init__(config, action_dim)
        self.n_bins, self.chunk = config.n_bins, config.chunk
        self.embed = nn.Embedding(config.chunk * action_dim * config.n_bins, config.latent_dim)
        self.decoder = nn.Linear(config.latent_dim, action_dim)

    @property
    def context_steps(self):
        return self.chunk

    def _forward(self, actions):  # (B, T, A)
        first = actions[:, :1].expand(-1, self.chunk - 1, -1)
        padded = torch.cat([first, actions], dim=1)  # (B, T + chunk - 1, A)
        windows = padded.unfold(1, self.chunk, 1).transpose(-1, -2)  # (B, T, chunk, A)
        codes = ((windows.clamp(-1, 1) + 1) / 2 * (self.n_bins - 1)).round().long()
        slots = torch.arange(self.chunk * self.action_dim, device=actions.device)
        ids = codes.flatten(2) + slots * self.n_bins  # (B, T, chunk * A)
        z = self.embed(ids).sum(2)  # (B, T, D)
        recon = self.decoder(z.detach())
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=codes[:, :, -1],
                               losses={"reconstruction": F.mse_loss(recon, actions)},
                               latents=z)
