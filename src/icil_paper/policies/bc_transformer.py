"""BC-Transformer: robomimic's transformer policy over an observation history, no prompt.

    o_(t-H+1) ... o_(t-1)  o_t         (H = BCTransformerConfig.history, edge-padded at the start)
        │           │       │
    ObservationEncoder (one token per step)
        │           │       │
    causal transformer (the same blocks as ICRT)
        │           │       │
      head        head    head ──> â_t   (executed)
    â_(t-H+1)    â_(t-1)

As in robomimic, every step of the window is supervised and the history is padded at an
episode's start by repeating the first observation. robomimic's head is a 5-mode GMM; ours
regresses the action with ICRT's and ACT's L1 loss. It ignores prompts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.policies.base import BatchedPolicy, masked_l1
from icil_paper.policies.batching import DemoSet, ObsSpec, window_batch
from icil_paper.policies.configs import BCTransformerConfig, register_policy_model
from icil_paper.policies.transformer import Transformer, TransformerConfig


@register_policy_model("bc_transformer")
class BCTransformer(BatchedPolicy):
    """Transformer over the last `history` observations; predicts one action per step."""

    name = "bc_transformer"

    def __init__(self, config: BCTransformerConfig, obs_dim: int | Mapping[str, Any] | ObsSpec,
                 action_dim: int, tokenizer: None = None):
        super().__init__(config, obs_dim, action_dim, None)
        D = config.d_model
        self.history = config.history
        self.obs_encoder = self.make_obs_encoder()
        self.transformer = Transformer(TransformerConfig(
            d_model=D, n_layer=config.n_layer, n_head=config.n_head, dropout=config.dropout,
            causal=True, rope=True))
        self.head = mlp([D, D, action_dim], nn.GELU)
        self._history: Tensor | None = None

    def sample_batch(self, data: DemoSet, batch_size: int, rng: np.random.Generator) -> dict[str, Any]:
        return window_batch(data, batch_size, self.history, 1, rng)

    def predict(self, obs: Mapping[str, Tensor], instructions=None) -> Tensor:
        """obs {key: (B, H, ...)} -> actions (B, H, A), one per history step."""
        h = self.transformer(self.obs_encoder(obs, instructions))
        return self.head(h)

    def forward(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, float]]:
        pred = self.predict(batch["obs"], batch.get("instruction"))  # (B, H, A)
        loss = masked_l1(pred, batch["actions"].float(), batch["obs_valid"])
        return loss, {"action_l1": float(loss.detach())}

    def reset_batch(self, prompts: Sequence[Any],
                    instructions: Sequence[str | None] | None = None) -> None:
        super().reset_batch(prompts, instructions)
        self._history: Tensor | None = None  # (B, H, D) the last H observation tokens

    @torch.no_grad()
    def select_actions(self, obs: Sequence[Mapping[str, np.ndarray]],
                       rows: Sequence[int] | None = None) -> np.ndarray:
        """One step of B episodes in one forward pass over their (B, H) histories."""
        keep = self.keep_rows(rows, len(obs))
        if keep is not None and self._history is not None:
            self._history = self._history[keep]
        token = self.obs_encoder(self.obs_tensors_batch(obs), self._instructions)  # (B, 1, D)
        if self._history is None:  # episode start: pad by repeating the first observation
            self._history = token.expand(-1, self.history, -1)
        else:
            self._history = torch.cat([self._history[:, 1:], token], dim=1)
        h = self.transformer(self._history)  # (B, H, D)
        return self.head(h[:, -1]).float().cpu().numpy()
