"""ACT (Zhao et al. 2023), scaled down to BC-Transformer's size, and Table II's ACT+tokenizer.

Plain ACT (`tokenizer=None`): a conditional VAE over the action chunk.

    training only:  [CLS, state, a_t, ..., a_(t+K-1)] ─ bidirectional encoder ─ CLS ─> mu, logvar ─> z
    always:         [z, state token, camera tokens...] ─ bidirectional encoder ─> memory
                    K learned queries ─ DETR decoder (self-attn, cross-attn to memory) ─> â_t .. â_(t+K-1)
    loss = L1(â, a) + kl_weight * KL(N(mu, sigma) || N(0, I));   at inference z = 0

At inference overlapping chunks are averaged (temporal ensembling). The blocks are this
library's Llama-style blocks with learned position embeddings.

ACT + tokenizer. The paper replaces "ACT's cVAE action encoder" with each tokenizer; our
reading: the policy predicts the tokenizer's latent, and actions are its decoding:

    memory = [state token, camera tokens...]      (no CVAE and no z)
    K queries ─ decoder ─ Linear ─> ẑ (B, K, D_tok) ─ tokenizer.decode ─> â (B, K, A)
    loss = L1(â, a) + MSE(ẑ, sg[tokenizer(a).embeddings]) + tokenizer losses

The target is detached; the tokenizer learns through its own losses.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.policies.base import BatchedPolicy, TemporalEnsemble, masked_l1
from icil_paper.policies.batching import DemoSet, ObsSpec, window_batch
from icil_paper.policies.configs import ACTConfig, register_policy_model
from icil_paper.policies.transformer import DecoderBlock, RMSNorm, Transformer, TransformerConfig
from icil_paper.tokenizers.configs import TokenizerConfig


@register_policy_model("act")
class ACT(BatchedPolicy):
    """Action chunking with transformers (ACTConfig); no tokenizer = the CVAE (plain ACT)."""

    name = "act"

    def __init__(self, config: ACTConfig, obs_dim: int | Mapping[str, Any] | ObsSpec,
                 action_dim: int, tokenizer: TokenizerConfig | None = None):
        super().__init__(config, obs_dim, action_dim, tokenizer)
        D, K = config.d_model, config.chunk_size
        self.chunk_size, self.kl_weight = K, config.kl_weight
        cfg = TransformerConfig(d_model=D, n_layer=config.n_layer, n_head=config.n_head,
                                dropout=config.dropout, causal=False, rope=False)
        self.obs_encoder = self.make_obs_encoder(separate=True)
        n_mem = self.obs_encoder.n_parts
        self.tokenizer = self.make_tokenizer()
        if self.tokenizer is None:  # the CVAE encoder and its latent z
            self.latent_dim = config.latent_dim
            self.cls = nn.Parameter(torch.zeros(1, 1, D))
            self.enc_state = nn.Linear(max(self.obs_spec.lowdim_dim, 1), D)
            self.enc_action = nn.Linear(action_dim, D)
            self.enc_pos = nn.Parameter(torch.randn(1, K + 2, D) * 0.02)
            self.cvae_encoder = Transformer(cfg)
            self.to_latent = nn.Linear(D, 2 * self.latent_dim)
            self.from_latent = nn.Linear(self.latent_dim, D)
            n_mem += 1
            out_dim = action_dim
        else:
            out_dim = self.tokenizer.latent_dim
        self.mem_pos = nn.Parameter(torch.randn(1, n_mem, D) * 0.02)
        self.memory_encoder = Transformer(cfg)
        self.queries = nn.Parameter(torch.randn(1, K, D) * 0.02)
        self.decoder = nn.ModuleList([DecoderBlock(cfg) for _ in range(config.n_layer)])
        self.dec_norm = RMSNorm(D)
        self.head = mlp([D, D, out_dim], nn.GELU)

    # ------------------------------------------------------------------ model
    def _cvae_posterior(self, obs: Mapping[str, Tensor], actions: Tensor,
                        valid: Tensor) -> tuple[Tensor, Tensor]:
        """[CLS, state, a_1..a_K] -> mu, logvar (B, latent)."""
        B = actions.shape[0]
        if self.obs_spec.lowdim_dim:
            state = self.obs_encoder.lowdim(obs)[:, -1]  # (B, lowdim)
        else:
            state = actions.new_zeros(B, 1)
        x = torch.cat([self.cls.expand(B, -1, -1), self.enc_state(state)[:, None],
                       self.enc_action(actions)], dim=1) + self.enc_pos  # (B, K + 2, D)
        tok_valid = torch.cat([valid.new_ones(B, 2), valid], dim=1)
        h = self.cvae_encoder(x, tok_valid)[:, 0]  # (B, D)
        mu, logvar = self.to_latent(h).chunk(2, dim=-1)
        return mu, logvar

    def decode_chunk(self, obs: Mapping[str, Tensor], instructions=None,
                     z: Tensor | None = None) -> Tensor:
        """Observation at one step {key: (B, 1, ...)} (+ z) -> decoder output (B, K, out)."""
        mem = self.obs_encoder(obs, instructions)[:, -1]  # (B, n_parts, D)
        if self.tokenizer is None:
            mem = torch.cat([self.from_latent(z)[:, None], mem], dim=1)
        memory = self.memory_encoder(mem + self.mem_pos)  # (B, n_mem, D)
        x = self.queries.expand(mem.shape[0], -1, -1)  # (B, K, D)
        for block in self.decoder:
            x = block(x, memory)
        return self.head(self.dec_norm(x))  # (B, K, out)

    # ------------------------------------------------------------------ training
    def sample_batch(self, data: DemoSet, batch_size: int, rng: np.random.Generator) -> dict[str, Any]:
        return window_batch(data, batch_size, 1, self.chunk_size, rng)

    def forward(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, float]]:
        obs, instr = batch["obs"], batch.get("instruction")
        target, valid = batch["targets"].float(), batch["target_valid"]  # (B, K, A), (B, K)
        if self.tokenizer is None:
            mu, logvar = self._cvae_posterior(obs, target, valid)
            z = mu + torch.randn_like(mu) * (0.5 * logvar).exp()
            pred = self.decode_chunk(obs, instr, z)
            l1 = masked_l1(pred, target, valid)
            kl = (-0.5 * (1 + logvar - mu.pow(2) - logvar.exp())).sum(-1).mean()
            return l1 + self.kl_weight * kl, {"action_l1": float(l1.detach()), "kl": float(kl.detach())}
        out = self.tokenizer(target)
        z_target = out.embeddings.detach()  # (B, K, D_tok)
        z_pred = self.decode_chunk(obs, instr)
        latent = ((z_pred - z_target).pow(2).mean(-1) * valid).sum() / valid.sum().clamp(min=1)
        actions = self.tokenizer.decode(z_pred)
        l1 = masked_l1(actions, target, valid)
        loss = latent + sum(out.losses.values())
        if actions.requires_grad:
            loss = loss + l1
        info = {"action_l1": float(l1.detach()), "latent_mse": float(latent.detach())}
        info.update({f"tok_{k}": float(v.detach()) for k, v in out.losses.items()})
        return loss, info

    # ------------------------------------------------------------------ acting
    @torch.no_grad()
    def predict_chunks(self, obs: Mapping[str, Tensor], instructions: Sequence[str]) -> np.ndarray:
        """Chunks (B, K, A) for observations {key: (B, 1, ...)} (z = 0 for plain ACT)."""
        B = len(instructions)
        if self.tokenizer is None:
            z = torch.zeros(B, self.latent_dim, device=self.device)
            chunk = self.decode_chunk(obs, list(instructions), z)
        else:
            chunk = self.tokenizer.decode(self.decode_chunk(obs, list(instructions)))
        return chunk.float().cpu().numpy()

    def reset_batch(self, prompts: Sequence[Any],
                    instructions: Sequence[str | None] | None = None) -> None:
        """Start B = len(prompts) episodes (prompts ignored), one temporal ensemble each."""
        super().reset_batch(prompts, instructions)
        self._ensembles = [TemporalEnsemble(self.chunk_size, self.config.ensemble_m)
                           for _ in self._instructions]

    @torch.no_grad()
    def select_actions(self, obs: Sequence[Mapping[str, np.ndarray]],
                       rows: Sequence[int] | None = None) -> np.ndarray:
        """One step of B episodes: their chunks in one forward pass, then each episode's
        temporal ensemble; obs[i] is episode rows[i]'s (default: all)."""
        keep = self.keep_rows(rows, len(obs))
        if keep is not None:
            self._ensembles = [self._ensembles[i] for i in keep.tolist()]
        chunks = self.predict_chunks(self.obs_tensors_batch(obs), self._instructions)
        return np.stack([ens(chunk) for ens, chunk in zip(self._ensembles, chunks, strict=True)]
                        ).astype(np.float32)
