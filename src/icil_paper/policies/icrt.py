"""ICRT: in-context imitation with a causal transformer over prompt and query (Sec. III-A).

    policy = make_policy("icrt", obs_dim, action_dim, tokenizer="lipvq")
    loss, info = policy(batch)                   # batch: policies.batching.prompt_query_batch
    policy.reset_batch(prompts); actions = policy.select_actions(obs_list)   # acting, B at once

    prompt o_p1 a_p1 ... o_pM a_pM, query o_q1 a_q1 ... o_qt   (layout: policies.batching)
      o: ObservationEncoder, a: tokenizer(actions).embeddings ─ MLP
      ─> causal transformer (transformer.py) ─> MLP head at query observation tokens ─> â_t..â_(t+K-1)

- Query actions in context, as ICRT's code (`query_actions=False`: Eq. 1 literally).
- Loss: L1 between the predicted chunk and the next K demonstrated actions on query steps,
  plus the tokenizer's own losses (trained jointly, as in the paper).
- A chunk tokenizer (C = `context_steps`) embeds step t from the C actions ending at t: the
  batch carries the C - 1 actions before the query window, and acting keeps the last C.
- Inference: the prompt runs once into a KV cache; each step appends the previous action's
  and the new observation's tokens, and executes the chunk's first action, clipped to [-1, 1].
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn
from torch.nn.utils.rnn import pad_sequence

from icil_paper.layers import mlp
from icil_paper.policies.base import BatchedPolicy, batch_instructions, masked_l1, validate_prompt
from icil_paper.policies.batching import DemoSet, ObsSpec, prompt_query_batch
from icil_paper.policies.configs import ICRTConfig, register_policy_model
from icil_paper.policies.transformer import Transformer, TransformerConfig
from icil_paper.tokenizers.configs import TokenizerConfig


def action_context_steps(tokenizer: nn.Module) -> int:
    """Actions up to and including step t that a tokenizer reads to embed step t."""
    if getattr(tokenizer, "mode", None) == "blocked":
        raise ValueError("FAST's blocked mode embeds a step with later actions of its chunk, "
                         "which a causal policy must not see; use mode='causal'")
    return max(1, int(tokenizer.context_steps))


@register_policy_model("icrt")
class ICRT(BatchedPolicy):
    """In-context robot transformer (ICRTConfig) with any action tokenizer (default `mlp`)."""

    name = "icrt"
    uses_prompt = True

    def __init__(self, config: ICRTConfig, obs_dim: int | Mapping[str, Any] | ObsSpec,
                 action_dim: int, tokenizer: TokenizerConfig):
        if tokenizer is None:
            raise ValueError("ICRT needs an action tokenizer config (make_policy gives the "
                             "default `mlp` when none is named)")
        super().__init__(config, obs_dim, action_dim, tokenizer)
        D, K = config.d_model, config.chunk_size
        self.chunk_size = K
        self.query_actions = config.query_actions
        self.max_seq_len = config.max_seq_len
        self.obs_encoder = self.make_obs_encoder()
        self.tokenizer = self.make_tokenizer()
        self.action_context = action_context_steps(self.tokenizer)
        # "another MLP ensures the same dimension" between action and observation tokens
        self.action_proj = mlp([self.tokenizer.latent_dim, D, D], nn.GELU)
        self.type_emb = nn.Embedding(2, D)  # 0: observation token, 1: action token
        nn.init.normal_(self.type_emb.weight, std=0.02)
        self.transformer = Transformer(TransformerConfig(
            d_model=D, n_layer=config.n_layer, n_head=config.n_head, dropout=config.dropout,
            causal=True, rope=True))
        self.head = mlp([D, D, K * action_dim], nn.GELU)
        self._cache = None

    # ------------------------------------------------------------------ tokens
    def obs_tokens(self, obs: Mapping[str, Tensor], instructions: Sequence[str] | None) -> Tensor:
        """obs {key: (B, T, ...)} -> (B, T, D)."""
        return self.obs_encoder(obs, instructions) + self.type_emb.weight[0]

    def action_tokens(self, actions: Tensor, context: Tensor | None = None
                      ) -> tuple[Tensor, dict[str, Tensor]]:
        """actions (B, T, A) -> tokens (B, T, D) and the tokenizer's losses; context
        (B, C - 1, A): the actions just before, which a chunk tokenizer reads."""
        B, T, A = actions.shape
        if A != self.action_dim:
            raise ValueError(f"wrong action dimension: got {A}, the policy expects {self.action_dim}")
        n_ctx = 0 if context is None else context.shape[1]
        x = actions if not n_ctx else torch.cat([context.to(actions), actions], dim=1)
        out = self.tokenizer(x)
        emb = out.embeddings[:, n_ctx:]  # (B, T, latent)
        return self.action_proj(emb) + self.type_emb.weight[1], out.losses

    def sequence(self, batch: Mapping[str, Any]) -> tuple[Tensor, Tensor, Tensor, dict[str, Tensor]]:
        """Assemble the token sequence of a batch (layout in `icil_paper.policies.batching`).

        Returns tokens (B, L, D), valid (B, L) bool, query_obs_index (N,) the positions of the
        query's observation tokens, and the tokenizer's losses (token-weighted mean of the
        prompt's and the query's).
        """
        instr = batch.get("instruction")
        pv, qv = batch["prompt_valid"], batch["query_valid"]  # (B, M), (B, N)
        B, M = pv.shape
        N = qv.shape[1]
        o_p = self.obs_tokens(batch["prompt_obs"], instr)  # (B, M, D)
        a_p, loss_p = self.action_tokens(batch["prompt_actions"].float())
        prompt = torch.stack([o_p, a_p], dim=2).reshape(B, 2 * M, -1)  # o1 a1 o2 a2 ...
        valid = [pv.repeat_interleave(2, dim=1)]
        o_q = self.obs_tokens(batch["query_obs"], instr)  # (B, N, D)
        if self.query_actions:
            a_q, loss_q = self.action_tokens(batch["query_actions"].float(),
                                             batch.get("query_action_context"))
            query = torch.stack([o_q, a_q], dim=2).reshape(B, 2 * N, -1)
            valid.append(qv.repeat_interleave(2, dim=1))
            q_index = 2 * M + 2 * torch.arange(N, device=o_q.device)
            n_p, n_q = B * M, B * N
            losses = {k: (loss_p[k] * n_p + loss_q[k] * n_q) / (n_p + n_q) for k in loss_p}
        else:
            query, losses = o_q, loss_p
            valid.append(qv)
            q_index = 2 * M + torch.arange(N, device=o_q.device)
        tokens = torch.cat([prompt, query], dim=1)  # (B, L, D)
        return tokens, torch.cat(valid, dim=1), q_index, losses

    # ------------------------------------------------------------------ training
    def sample_batch(self, data: DemoSet, batch_size: int, rng: np.random.Generator) -> dict[str, Any]:
        c = self.config
        return prompt_query_batch(data, batch_size, c.query_len, self.chunk_size,
                                  c.prompt_demos, rng, action_context=self.action_context - 1,
                                  query_start=c.query_start, prompt_from=c.prompt_from)

    def predict(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, Tensor]]:
        """Predicted chunks (B, N, K, A) at every query step, and the tokenizer's losses."""
        tokens, valid, q_index, losses = self.sequence(batch)
        if tokens.shape[1] > self.max_seq_len:
            raise ValueError(
                f"sequence of {tokens.shape[1]} tokens (prompt {batch['prompt_valid'].shape[1]} "
                f"steps, query {batch['query_valid'].shape[1]} steps) is longer than "
                f"max_seq_len={self.max_seq_len}; raise ICRTConfig.max_seq_len or use "
                "shorter demonstrations")
        h = self.transformer(tokens, valid)  # (B, L, D)
        h_q = h[:, q_index]  # (B, N, D): the query's observation tokens
        B, N, _ = h_q.shape
        return self.head(h_q).view(B, N, self.chunk_size, self.action_dim), losses

    def forward(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, float]]:
        pred, tok_losses = self.predict(batch)
        action_loss = masked_l1(pred, batch["targets"].float(), batch["target_valid"])
        loss = action_loss + sum(tok_losses.values())
        info = {"action_l1": float(action_loss.detach())}
        info.update({f"tok_{k}": float(v.detach()) for k, v in tok_losses.items()})
        return loss, info

    # ------------------------------------------------------------------ acting
    @torch.no_grad()
    def reset_batch(self, prompts: Sequence[Any],
                    instructions: Sequence[str | None] | None = None) -> None:
        """Start B = len(prompts) episodes: run every prompt through the transformer in one
        padded batch into one KV cache (padding is never attended to)::

            row 0   o a o a o a o a │ o a o a ...     (the query steps of all rows
            row 1   o a o a . . . . │ o a o a ...      share columns)

        instructions[b]: episode b's instruction (None: its first demonstration's).
        """
        instructions = batch_instructions(prompts, instructions)
        keys, rows_obs, rows_actions, texts = self.obs_spec.keys, [], [], []
        for prompt, text in zip(prompts, instructions, strict=True):
            demos = validate_prompt(prompt, self.obs_spec, self.action_dim)
            texts.append(text if text is not None else getattr(demos[0], "instruction", "") or "")
            rows_obs.append({k: np.concatenate([np.asarray(d.obs[k]) for d in demos]) for k in keys})
            rows_actions.append(np.concatenate([np.asarray(d.actions, np.float32) for d in demos]))
        lengths = [len(a) for a in rows_actions]
        B, M = len(lengths), max(lengths)
        if 2 * M + 2 > self.max_seq_len:
            raise ValueError(f"a prompt of {M} steps ({2 * M} tokens) leaves no room for the "
                             f"query within max_seq_len={self.max_seq_len}")
        dev = self.device
        # (B, M, ...) each, zero after a row's end
        obs = {k: pad_sequence([torch.from_numpy(o[k]) for o in rows_obs], batch_first=True)
               .to(dev) for k in keys}
        obs = {k: v.float() if k != "rgb" else v for k, v in obs.items()}
        actions = pad_sequence([torch.from_numpy(a) for a in rows_actions], batch_first=True).to(dev)
        valid = torch.arange(M, device=dev)[None] < torch.tensor(lengths, device=dev)[:, None]
        o_p = self.obs_tokens(obs, texts)
        a_p, _ = self.action_tokens(actions)
        tokens = torch.stack([o_p, a_p], dim=2).reshape(B, 2 * M, -1)  # o1 a1 o2 a2 ...
        self._cache = self.transformer.new_cache()
        self.transformer(tokens, valid.repeat_interleave(2, dim=1), cache=self._cache)
        self._prompt_len = 2 * torch.tensor(lengths, device=dev)  # (B,) real prompt tokens
        self._recent: Tensor | None = None  # (B, <= C, A) executed query actions
        self.begin_episodes(texts)

    @torch.no_grad()
    def select_actions(self, obs: Sequence[Mapping[str, np.ndarray]],
                       rows: Sequence[int] | None = None) -> np.ndarray:
        """One step of the episodes of `reset_batch`, in one forward pass: append each row's
        (previous action, observation) and return (len(obs), A) actions, each chunk's first,
        clipped to [-1, 1]. obs[i] belongs to episode rows[i] (default: all, in order)."""
        if self._cache is None:
            raise RuntimeError("call reset(prompt=...) (or reset_batch) before select_action")
        keep = self.keep_rows(rows, len(obs))
        if keep is not None:  # finished episodes drop out of the batch
            self._cache.select_rows(keep)
            self._prompt_len = self._prompt_len[keep]
            self._recent = None if self._recent is None else self._recent[keep]
        new = []
        if self.query_actions and self._recent is not None:
            recent = self._recent  # (B, <= C, A)
            new.append(self.action_tokens(recent[:, -1:], recent[:, :-1])[0])
        new.append(self.obs_tokens(self.obs_tensors_batch(obs), self._instructions))
        x = torch.cat(new, dim=1)  # (B, 1 or 2, D)
        self._make_room(x.shape[1])
        h = self.transformer(x, cache=self._cache)[:, -1]  # (B, D)
        chunk = self.head(h).view(len(obs), self.chunk_size, self.action_dim)
        action = chunk[:, 0].clamp(-1.0, 1.0)  # (B, A)
        recent = action[:, None] if self._recent is None else torch.cat(
            [self._recent, action[:, None]], dim=1)
        self._recent = recent[:, -self.action_context:]
        return action.float().cpu().numpy()

    def _make_room(self, n_new: int) -> None:
        # hide each row's oldest query steps (whole pairs) once it would exceed max_seq_len
        cache = self._cache
        overflow = cache.valid.sum(dim=1) + n_new - self.max_seq_len  # (B,)
        if bool((overflow > 0).any()):
            step = 2 if self.query_actions else 1
            overflow = step * torch.div(overflow.clamp(min=0) + step - 1, step,
                                        rounding_mode="floor")
            rank = cache.valid.long().cumsum(dim=1) - 1  # index among the row's real tokens
            first = self._prompt_len[:, None]
            cache.invalidate(cache.valid & (rank >= first) & (rank < first + overflow[:, None]))
