"""BC-Transformer: robomimic's transformer policy over an observation history, no prompt.

    o_(t-H+1) ... o_(t-1)  o_t         (H = BCTransformerConfig.history, edge-padded at the start)
        │           │       │
    ObservationEncoder (one token per step)
        │           │       │
    causal transformer (the same blocks as ICRT)
        │           │       │
      head        head    head ──> â_t   (executed)
    â_(t-H+1)    â_(t-1)

As in robomimic, every step of the window is supervised (`supervise_all_steps`) and the
history is padded at an episode's start by repeating the first observation, at training
and at inference alike. robomimic's head is a 5-mode GMM; ours regresses the action with an
L1 loss, the same loss as ICRT and ACT here, so that the comparison is about context and
not about the output distribution. It sees no prompt: `reset(prompt)` ignores the prompt.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.batching import DemoSet, window_batch
from icil_paper.layers import mlp
from icil_paper.policies.backbones import ObsSpec
from icil_paper.policies.base import Policy, masked_l1
from icil_paper.policies.configs import BCTransformerConfig
from icil_paper.policies.transformer import Transformer, TransformerConfig


class BCTransformer(Policy):
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
        self._tokens: deque[Tensor] = deque(maxlen=self.history)

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

    def reset(self, prompt: Any = None, instruction: str | None = None) -> None:
        super().reset(instruction=instruction)
        self._tokens.clear()

    @torch.no_grad()
    def select_action(self, obs: Mapping[str, np.ndarray]) -> np.ndarray:
        token = self.obs_encoder(self.obs_tensors(obs), [self.instruction])  # (1, 1, D)
        if not self._tokens:  # episode start: pad by repeating the first observation
            self._tokens.extend([token] * (self.history - 1))
        self._tokens.append(token)
        h = self.transformer(torch.cat(list(self._tokens), dim=1))  # (1, H, D)
        return self.head(h[:, -1])[0].cpu().numpy().astype(np.float32)
