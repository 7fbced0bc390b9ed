"""A readable Llama-style transformer: RMSNorm, rotary position embeddings, SwiGLU, KV cache.

One file, in the spirit of nanoGPT. ICRT and BC-Transformer use `Transformer` with causal
self-attention; ACT uses the same blocks without the causal mask (its encoders) and
`DecoderBlock` (self-attention, cross-attention, feed-forward) for its DETR-style decoder.

Shapes: B batch, T tokens, D = d_model, H heads, hd = D / H head width.

    x (B, T, D) ─┬─ RMSNorm ─ Attention(RoPE, mask, KV cache) ─(+)─┬─ RMSNorm ─ SwiGLU ─(+)─> (B, T, D)
                 └──────────────────────────────────────────────┘  └──────────────────────┘

Masks: a boolean `attn_mask` (B, 1, T_query, T_key), True = attend, built by `causal_mask`
from a per-token validity mask, so padded batches need no moving of tokens: padding is never
attended to, and each token always attends to itself (a padding row is well defined).

Positions: rotary embeddings from integer positions that count real tokens only. Keys are
rotated before they enter the cache, so dropping old cache entries is safe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn


@dataclass(frozen=True)
class TransformerConfig:
    """Sizes of a transformer stack."""

    d_model: int = 128
    """Token width D."""
    n_layer: int = 4
    """Number of blocks."""
    n_head: int = 4
    """Attention heads H (D must be divisible by H)."""
    dropout: float = 0.0
    """Dropout on attention weights and on each residual branch."""
    causal: bool = True
    """Causal self-attention (a token attends to itself and earlier tokens only)."""
    rope: bool = True
    """Rotary position embeddings on queries and keys; without them positions must be added
    to the input (ACT's learned position embeddings)."""
    rope_base: float = 10_000.0
    """Base of the rotary frequencies."""
    ffn_multiple: int = 16
    """SwiGLU hidden width is 8/3 D rounded up to a multiple of this (Llama's rule)."""


class RMSNorm(nn.Module):
    """Root-mean-square layer norm (no mean subtraction, no bias), as in Llama."""

    def __init__(self, dim: int, eps: float = 1e-6):
        super().__init__()
        self.eps = eps
        self.weight = nn.Parameter(torch.ones(dim))

    def forward(self, x: Tensor) -> Tensor:
        # x (..., D): scale each vector to unit RMS, then by a learned gain
        return x * torch.rsqrt(x.pow(2).mean(-1, keepdim=True) + self.eps) * self.weight


def rope_cos_sin(positions: Tensor, head_dim: int, base: float = 10_000.0) -> tuple[Tensor, Tensor]:
    """Rotary angles for integer positions (B, T) -> cos, sin each (B, 1, T, head_dim)."""
    inv_freq = 1.0 / (base ** (torch.arange(0, head_dim, 2, device=positions.device,
                                             dtype=torch.float32) / head_dim))  # (hd/2,)
    angles = positions.to(torch.float32)[..., None] * inv_freq  # (B, T, hd/2)
    angles = torch.cat([angles, angles], dim=-1)[:, None]  # (B, 1, T, hd)
    return angles.cos(), angles.sin()


def apply_rope(x: Tensor, cos: Tensor, sin: Tensor) -> Tensor:
    """Rotate feature pairs (i, i + hd/2) of x (B, H, T, hd) by the given angles."""
    half = x.shape[-1] // 2
    rotated = torch.cat([-x[..., half:], x[..., :half]], dim=-1)  # "rotate_half"
    return (x * cos.to(x.dtype) + rotated * sin.to(x.dtype)).type_as(x)


def causal_mask(valid: Tensor, past_valid: Tensor | None = None, causal: bool = True) -> Tensor:
    """Boolean attention mask (B, 1, T, P + T) for T new tokens after P cached ones.

    valid: (B, T) bool, which new tokens are real (False = padding).
    past_valid: (B, P) bool for the cached tokens, or None when there is no cache.
    A query attends to keys that are real and (if causal) not after it, and always to itself.
    """
    B, T = valid.shape
    P = 0 if past_valid is None else past_valid.shape[1]
    keys_valid = valid if past_valid is None else torch.cat([past_valid, valid], dim=1)  # (B, P+T)
    q_index = torch.arange(T, device=valid.device)[:, None] + P  # (T, 1) absolute positions
    k_index = torch.arange(P + T, device=valid.device)[None, :]  # (1, P+T)
    allowed = keys_valid[:, None, :].expand(B, T, P + T)
    if causal:
        allowed = allowed & (k_index <= q_index)[None]
    allowed = allowed | (k_index == q_index)[None]  # always attend to yourself
    return allowed[:, None]  # (B, 1, T, P+T)


def positions_from_valid(valid: Tensor, start: Tensor | int = 0) -> Tensor:
    """Integer positions (B, T) that count only real tokens: padding does not shift positions.

    `start` (an int or a (B,) tensor) is the position of the first real token.
    """
    pos = valid.long().cumsum(dim=1) - 1  # (B, T)
    pos = pos.clamp(min=0)
    if isinstance(start, Tensor):
        start = start[:, None]
    return pos + start


class KVCache:
    """Keys and values of every layer for the tokens seen so far (inference only).

    valid: (B, P) bool, which cached columns are real tokens; next_position: (B,) the position
    the next real token gets. Each layer's keys and values (B, H, P, hd) live in a buffer that
    doubles when full, so appending a step copies only the new columns.

    Rows are independent sequences (a batch of episodes). `select_rows` keeps some rows and
    `invalidate` hides single rows' columns; both then drop the columns no row uses.
    """

    def __init__(self, n_layer: int):
        self._keys: list[Tensor | None] = [None] * n_layer
        self._values: list[Tensor | None] = [None] * n_layer
        self._used = [0] * n_layer
        self.valid: Tensor | None = None
        self.next_position: Tensor | None = None

    def __len__(self) -> int:
        return 0 if self.valid is None else self.valid.shape[1]

    def append(self, layer: int, k: Tensor, v: Tensor) -> tuple[Tensor, Tensor]:
        """Add this step's keys/values (B, H, T, hd) of one layer; return all of them."""
        n, T = self._used[layer], k.shape[2]
        buf = self._keys[layer]
        if buf is None or n + T > buf.shape[2]:
            capacity = max(2 * (n + T), 64)
            new_k = k.new_empty(*k.shape[:2], capacity, k.shape[3])
            new_v = v.new_empty(*v.shape[:2], capacity, v.shape[3])
            if n:
                new_k[:, :, :n] = self._keys[layer][:, :, :n]
                new_v[:, :, :n] = self._values[layer][:, :, :n]
            self._keys[layer], self._values[layer] = new_k, new_v
        self._keys[layer][:, :, n:n + T] = k
        self._values[layer][:, :, n:n + T] = v
        self._used[layer] = n + T
        return self._keys[layer][:, :, :n + T], self._values[layer][:, :, :n + T]

    def invalidate(self, hide: Tensor) -> None:
        """Hide the cached tokens where `hide` (B, P) bool is True."""
        self.valid = self.valid & ~hide
        self._compact()

    def select_rows(self, rows: Tensor | list[int]) -> None:
        """Keep only these rows (e.g. the episodes still running), in this order."""
        rows = torch.as_tensor(rows, dtype=torch.long, device=self.valid.device)
        self.valid, self.next_position = self.valid[rows], self.next_position[rows]
        self._compact(rows)

    def _compact(self, rows: Tensor | None = None) -> None:
        """Keep `rows` of every layer's buffers (all: None) and drop the columns no row uses."""
        keep = self.valid.any(dim=0)  # (P,)
        drop = not bool(keep.all())
        if rows is None and not drop:
            return
        for i, n in enumerate(self._used):
            if self._keys[i] is None:
                continue
            k, v = self._keys[i][:, :, :n], self._values[i][:, :, :n]
            if rows is not None:
                k, v = k[rows], v[rows]
            if drop:
                k, v = k[:, :, keep], v[:, :, keep]
            self._keys[i], self._values[i] = k.contiguous(), v.contiguous()
            self._used[i] = k.shape[2]
        if drop:
            self.valid = self.valid[:, keep]


class Attention(nn.Module):
    """Multi-head attention; self-attention by default, cross-attention when given a context."""

    def __init__(self, cfg: TransformerConfig, cross: bool = False):
        super().__init__()
        assert cfg.d_model % cfg.n_head == 0, "d_model must be divisible by n_head"
        self.n_head, self.head_dim = cfg.n_head, cfg.d_model // cfg.n_head
        self.rope = cfg.rope and not cross
        self.q = nn.Linear(cfg.d_model, cfg.d_model, bias=False)
        self.k = nn.Linear(cfg.d_model, cfg.d_model, bias=False)
        self.v = nn.Linear(cfg.d_model, cfg.d_model, bias=False)
        self.proj = nn.Linear(cfg.d_model, cfg.d_model, bias=False)
        self.dropout = cfg.dropout

    def _heads(self, x: Tensor) -> Tensor:
        B, T, _ = x.shape
        return x.view(B, T, self.n_head, self.head_dim).transpose(1, 2)  # (B, H, T, hd)

    def forward(self, x: Tensor, attn_mask: Tensor | None = None,
                context: Tensor | None = None, cache: KVCache | None = None, layer: int = 0,
                rope: tuple[Tensor, Tensor] | None = None) -> Tensor:
        """x (B, T, D) -> (B, T, D). Keys/values come from `context` (B, S, D) if given;
        `rope`: the rotary (cos, sin) of the tokens' positions (`rope_cos_sin`)."""
        source = x if context is None else context
        q, k, v = self._heads(self.q(x)), self._heads(self.k(source)), self._heads(self.v(source))
        if self.rope:
            q, k = apply_rope(q, *rope), apply_rope(k, *rope)
        if cache is not None:
            k, v = cache.append(layer, k, v)  # (B, H, P + T, hd)
        y = F.scaled_dot_product_attention(
            q, k, v, attn_mask=attn_mask, dropout_p=self.dropout if self.training else 0.0)
        B, _, T, _ = y.shape
        return self.proj(y.transpose(1, 2).reshape(B, T, -1))  # (B, T, D)


class SwiGLU(nn.Module):
    """Llama's gated feed-forward: W2 (silu(W1 x) * W3 x)."""

    def __init__(self, cfg: TransformerConfig):
        super().__init__()
        hidden = int(8 * cfg.d_model / 3)
        hidden = cfg.ffn_multiple * math.ceil(hidden / cfg.ffn_multiple)
        self.w1 = nn.Linear(cfg.d_model, hidden, bias=False)
        self.w3 = nn.Linear(cfg.d_model, hidden, bias=False)
        self.w2 = nn.Linear(hidden, cfg.d_model, bias=False)

    def forward(self, x: Tensor) -> Tensor:
        return self.w2(F.silu(self.w1(x)) * self.w3(x))


class Block(nn.Module):
    """Pre-norm transformer block: x + Attn(norm(x)), then + SwiGLU(norm(x))."""

    def __init__(self, cfg: TransformerConfig):
        super().__init__()
        self.norm1, self.attn = RMSNorm(cfg.d_model), Attention(cfg)
        self.norm2, self.mlp = RMSNorm(cfg.d_model), SwiGLU(cfg)
        self.drop = nn.Dropout(cfg.dropout)

    def forward(self, x: Tensor, attn_mask: Tensor | None, cache: KVCache | None = None,
                layer: int = 0, rope: tuple[Tensor, Tensor] | None = None) -> Tensor:
        x = x + self.drop(self.attn(self.norm1(x), attn_mask, cache=cache, layer=layer,
                                    rope=rope))
        return x + self.drop(self.mlp(self.norm2(x)))


class DecoderBlock(nn.Module):
    """DETR-style decoder block: self-attention, cross-attention to a memory, SwiGLU."""

    def __init__(self, cfg: TransformerConfig):
        super().__init__()
        self.norm1, self.self_attn = RMSNorm(cfg.d_model), Attention(cfg)
        self.norm2, self.cross_attn = RMSNorm(cfg.d_model), Attention(cfg, cross=True)
        self.norm3, self.mlp = RMSNorm(cfg.d_model), SwiGLU(cfg)
        self.drop = nn.Dropout(cfg.dropout)

    def forward(self, x: Tensor, memory: Tensor, memory_mask: Tensor | None = None) -> Tensor:
        """x (B, K, D) queries, memory (B, S, D); memory_mask (B, 1, 1, S) bool or None."""
        x = x + self.drop(self.self_attn(self.norm1(x)))
        x = x + self.drop(self.cross_attn(self.norm2(x), memory_mask, context=memory))
        return x + self.drop(self.mlp(self.norm3(x)))


class Transformer(nn.Module):
    """A stack of `Block`s with a final RMSNorm; optional KV cache for incremental decoding.

        y = model(x)                                  # (B, T, D), all tokens real
        y = model(x, valid=valid)                     # padded batch, valid (B, T) bool
        cache = model.new_cache()
        y1 = model(x[:, :10], cache=cache)            # prefill
        y2 = model(x[:, 10:11], cache=cache)          # one more token, reusing the cache
        # torch.cat([y1, y2], 1) equals model(x[:, :11]) up to float rounding
    """

    def __init__(self, cfg: TransformerConfig):
        super().__init__()
        self.cfg = cfg
        self.blocks = nn.ModuleList([Block(cfg) for _ in range(cfg.n_layer)])
        self.norm = RMSNorm(cfg.d_model)
        self.apply(_init_weights)

    def new_cache(self) -> KVCache:
        return KVCache(self.cfg.n_layer)

    def forward(self, x: Tensor, valid: Tensor | None = None,
                cache: KVCache | None = None) -> Tensor:
        """x (B, T, D) -> (B, T, D). valid (B, T) bool marks real tokens (default: all)."""
        B, T, _ = x.shape
        if valid is None:
            valid = torch.ones(B, T, dtype=torch.bool, device=x.device)
        past_valid = cache.valid if cache is not None and len(cache) else None
        start = cache.next_position if past_valid is not None else 0
        positions = positions_from_valid(valid, start)  # (B, T)
        mask = causal_mask(valid, past_valid, causal=self.cfg.causal)  # (B, 1, T, P+T)
        if cache is not None:
            cache.valid = valid if past_valid is None else torch.cat([past_valid, valid], dim=1)
            cache.next_position = start + valid.long().sum(dim=1)  # (B,)
        rope = None
        if self.cfg.rope:  # the same angles in every layer: computed once
            rope = rope_cos_sin(positions, self.cfg.d_model // self.cfg.n_head, self.cfg.rope_base)
        for i, block in enumerate(self.blocks):
            x = block(x, mask, cache=cache, layer=i, rope=rope)
        return self.norm(x)


def _init_weights(module: nn.Module) -> None:
    """GPT-2 style initialisation: normal(0, 0.02) linear weights, zero biases."""
    if isinstance(module, nn.Linear):
        nn.init.normal_(module.weight, mean=0.0, std=0.02)
        if module.bias is not None:
            nn.init.zeros_(module.bias)
    elif isinstance(module, nn.Embedding):
        nn.init.normal_(module.weight, mean=0.0, std=0.02)
