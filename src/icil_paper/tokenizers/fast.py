"""`fast`: FAST (Pertsch et al. 2025), DCT compression of action chunks plus BPE.

Per chunk of `chunk` steps (C, A):

    coefficients = scipy.fft.dct(chunk, axis=time, norm="ortho")      (C, A)
    integers     = round(scale * coefficients)                         (C, A)
    symbols      = integers flattened frequency-major, shifted to be non-negative
    tokens       = BPE(symbols), a vocabulary of `vocab_size` trained by `fit`

Decoding inverts every step (the DCT is orthonormal: a chunk's round-trip error is at most
sqrt(C * A) / (2 scale)); values outside the range seen in `fit` are clipped. A malformed
token sequence raises `FastDecodeError` in `decode_tokens` (or, with `strict=False`, gives
NaN actions and `ok` False).

One embedding per step: a chunk's token embeddings plus position embeddings, mean-pooled.
`mode="causal"`: step t is the chunk of the actions ending at t (left-padded with the first
action). `mode="blocked"`: FAST's own non-overlapping chunks (later actions leak into a
step, which ICRT refuses). `decode(embeddings)` is a learned MLP head.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import Tensor, nn
from torch.nn.utils.rnn import pad_sequence

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import (
    ActionTokenizer,
    TokenizerOutput,
    as_trajectory_list,
    causal_chunks,
)
from icil_paper.tokenizers.configs import FASTConfig, register_tokenizer_model

# Symbol of integer v is chr(v - min_token + _CHAR_OFFSET). 0 is kept free because NumPy's
# fixed-width strings (used to build symbol strings fast) drop trailing NUL characters.
_CHAR_OFFSET = 1


class FastDecodeError(ValueError):
    """A FAST token sequence that does not decode to a whole chunk of actions."""


def _token_ids(ids, index: int) -> list[int]:
    """One sequence's token ids as ints; FastDecodeError for anything but whole numbers."""
    out = []
    for j in ids:
        if isinstance(j, (bool, np.bool_)) or not isinstance(j, (int, np.integer, float,
                                                                 np.floating)):
            raise FastDecodeError(f"sequence {index}: token id {j!r} is not an integer")
        if isinstance(j, (float, np.floating)) and not float(j).is_integer():
            raise FastDecodeError(f"sequence {index}: token id {j!r} is not a whole number")
        out.append(int(j))
    return out


@register_tokenizer_model("fast")
class FASTTokenizer(ActionTokenizer):
    """DCT + BPE action tokenizer with per-step pooled token embeddings (FASTConfig)."""

    name = "fast"
    discrete = True
    needs_fit = True

    def __init__(self, config: FASTConfig, action_dim: int):
        super().__init__(config, action_dim)
        latent_dim = config.latent_dim
        self.chunk = int(config.chunk)
        self.scale = float(config.scale)
        self.vocab_size = int(config.vocab_size)
        self.mode = config.mode
        self.symbols_per_chunk = self.chunk * action_dim
        self.token_embedding = nn.Embedding(self.vocab_size, latent_dim)
        self.token_position = nn.Embedding(self.symbols_per_chunk, latent_dim)
        self.step_position = nn.Embedding(self.chunk, latent_dim)
        self.decoder = mlp([latent_dim, *config.hidden[::-1], action_dim])
        self.min_token = 0
        self.max_token = 0
        self._bpe = None
        self._vocab: list[str] = []

    # ------------------------------------------------------------------ fitting
    def _fit(self, trajectories: list[np.ndarray]) -> None:
        from tokenizers import Tokenizer, models, trainers

        chunks = np.concatenate([self._blocked_chunks(t[None])[0] for t in trajectories])
        ints = self._quantize(chunks)  # (N, C, A)
        self.min_token, self.max_token = int(ints.min()), int(ints.max())
        n_symbols = self.max_token - self.min_token + 1
        if n_symbols > self.vocab_size:
            raise ValueError(
                f"FAST needs {n_symbols} base symbols (integers {self.min_token}..{self.max_token}"
                f" at scale {self.scale}) but vocab_size is {self.vocab_size}; "
                "lower fast_scale or raise fast_vocab_size")
        strings = self._symbol_strings(ints)
        bpe = Tokenizer(models.BPE())
        trainer = trainers.BpeTrainer(
            vocab_size=self.vocab_size, min_frequency=int(self.config.min_frequency), show_progress=False,
            special_tokens=[], max_token_length=10000,
            initial_alphabet=[chr(i + _CHAR_OFFSET) for i in range(n_symbols)])
        bpe.train_from_iterator(strings, trainer, length=len(strings))
        self._set_bpe(bpe)

    def _set_bpe(self, bpe) -> None:
        self._bpe = bpe
        self._vocab = [bpe.id_to_token(i) for i in range(bpe.get_vocab_size())]

    def get_extra_state(self) -> dict:
        """The BPE vocabulary and symbol range travel with `state_dict()`."""
        return {"bpe": self._bpe.to_str() if self._bpe is not None else None,
                "min_token": self.min_token, "max_token": self.max_token}

    def set_extra_state(self, state: dict) -> None:
        from tokenizers import Tokenizer

        self.min_token, self.max_token = state["min_token"], state["max_token"]
        if state["bpe"] is not None:
            self._set_bpe(Tokenizer.from_str(state["bpe"]))

    @property
    def bpe_vocab_size(self) -> int:
        """Tokens in the fitted BPE vocabulary (at most `vocab_size`)."""
        return len(self._vocab)

    # ------------------------------------------------------------------ chunks
    def _blocked_chunks(self, actions: np.ndarray) -> np.ndarray:
        """(B, T, A) -> (B, ceil(T / C), C, A), the last chunk padded with the last action."""
        b, t, a = actions.shape
        n = -(-t // self.chunk)
        padded = np.concatenate([actions, np.repeat(actions[:, -1:], n * self.chunk - t, 1)], 1)
        return padded.reshape(b, n, self.chunk, a)

    def _quantize(self, chunks: np.ndarray) -> np.ndarray:
        """Chunks (..., C, A) -> rounded scaled DCT coefficients (..., C, A), int64."""
        from scipy.fft import dct

        return np.rint(dct(chunks, axis=-2, norm="ortho") * self.scale).astype(np.int64)

    def _dequantize(self, ints: np.ndarray) -> np.ndarray:
        from scipy.fft import idct

        return idct(ints / self.scale, axis=-2, norm="ortho")

    def _symbol_strings(self, ints: np.ndarray) -> list[str]:
        """Integers (N, C, A) -> one string of C * A symbols per chunk (frequency-major)."""
        flat = np.clip(ints.reshape(len(ints), -1), self.min_token, self.max_token)
        codes = (flat - self.min_token + _CHAR_OFFSET).astype(np.uint32)
        # A (N, L) uint32 array viewed as N fixed-width unicode strings of L characters.
        return np.ascontiguousarray(codes).view(f"<U{codes.shape[1]}").ravel().tolist()

    # ------------------------------------------------------------------ tokens
    def encode_tokens(self, chunks) -> list[list[int]]:
        """Action chunks (N, C, A) -> N token id lists."""
        self._require_fit()
        chunks = np.asarray(chunks, dtype=np.float64)
        if chunks.ndim != 3 or chunks.shape[1:] != (self.chunk, self.action_dim):
            raise ValueError(f"chunks must be shaped (N, {self.chunk}, {self.action_dim}), "
                             f"got {chunks.shape}")
        if not np.isfinite(chunks).all():
            raise ValueError("chunks contain NaN or inf values; FAST encodes finite actions only")
        if len(chunks) == 0:
            return []
        strings = self._symbol_strings(self._quantize(chunks))
        return [e.ids for e in self._bpe.encode_batch(strings)]

    def decode_tokens(self, tokens: Sequence[Sequence[int]], strict: bool = True
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Token id lists -> (actions (N, C, A), ok (N,) bool); a malformed sequence raises
        FastDecodeError when `strict`, else its actions are NaN and `ok` False."""
        self._require_fit()
        n_sym = self.symbols_per_chunk
        ints = np.zeros((len(tokens), n_sym), dtype=np.int64)
        ok = np.ones(len(tokens), dtype=bool)
        problems = []
        for i, ids in enumerate(tokens):
            ids = _token_ids(ids, i)
            bad = [j for j in ids if not 0 <= j < len(self._vocab)]
            if bad:
                ok[i] = False
                problems.append(f"sequence {i}: token ids {bad[:5]} outside the vocabulary "
                                f"of {len(self._vocab)}")
                continue
            symbols = "".join(self._vocab[j] for j in ids)
            if len(symbols) != n_sym:
                ok[i] = False
                problems.append(f"sequence {i}: {len(ids)} tokens decode to {len(symbols)} "
                                f"coefficients, a chunk needs {n_sym}")
                continue
            ints[i] = np.frombuffer(symbols.encode("utf-32-le"), dtype=np.uint32)
        if problems and strict:
            raise FastDecodeError(f"{len(problems)} malformed FAST token sequence(s): "
                                  + "; ".join(problems[:5]))
        ints = ints - _CHAR_OFFSET + self.min_token
        actions = self._dequantize(ints.reshape(-1, self.chunk, self.action_dim))
        actions[~ok] = np.nan
        return actions, ok

    def _require_fit(self) -> None:
        if self._bpe is None:
            raise RuntimeError("the fast tokenizer must be fitted first: call tokenizer.fit(...)")

    # ------------------------------------------------------------------ forward
    def _pool(self, ids: Tensor) -> Tensor:
        """Token ids (N, L) padded with -1 -> mean of token + position embeddings (N, D)."""
        mask = (ids >= 0).unsqueeze(-1)  # (N, L, 1)
        positions = torch.arange(ids.shape[1], device=ids.device)
        emb = self.token_embedding(ids.clamp(min=0)) + self.token_position(positions)
        return (emb * mask).sum(1) / mask.sum(1).clamp(min=1)

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        self._require_fit()
        b, t, a = actions.shape
        x = actions.detach().cpu().double()
        if self.mode == "causal":
            chunks = causal_chunks(x, self.chunk).numpy()  # (B, T, C, A)
        else:
            chunks = self._blocked_chunks(x.numpy())  # (B, n, C, A)
        n = chunks.shape[1]
        ints = self._quantize(chunks.reshape(b * n, self.chunk, a))
        ints = np.clip(ints, self.min_token, self.max_token)
        ids = pad_sequence([torch.tensor(e.ids, dtype=torch.long) for e in
                            self._bpe.encode_batch(self._symbol_strings(ints))],
                           batch_first=True, padding_value=-1).to(actions.device)  # (B * n, L)
        pooled = self._pool(ids).view(b, n, -1)  # (B, n, D)
        recon_chunks = self._dequantize(ints).reshape(b, n, self.chunk, a)
        if self.mode == "causal":
            z = pooled  # (B, T, D)
            recon = recon_chunks[:, :, -1]  # each step is the last row of its own chunk
        else:
            steps = torch.arange(t, device=actions.device)
            z = pooled.repeat_interleave(self.chunk, dim=1)[:, :t]
            z = z + self.step_position(steps % self.chunk)
            recon = recon_chunks.reshape(b, n * self.chunk, a)[:, :t]
        recon = torch.as_tensor(recon, dtype=actions.dtype, device=actions.device)
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=ids.view(b, n, -1),
                               losses=self.decode_losses(z, actions))

    # ------------------------------------------------------------------ facts
    @property
    def context_steps(self) -> int:
        """`chunk` in causal mode (step t depends on steps t - chunk + 1 .. t)."""
        return self.chunk

    @property
    def codebook_size(self) -> int:
        """Tokens in the BPE vocabulary (the configured size before fitting)."""
        return self.bpe_vocab_size or self.vocab_size

    def tokens_per_step(self, actions=None) -> float:
        """Tokens of non-overlapping chunks per action step over `actions` (required)."""
        if actions is None:
            raise ValueError("FAST's tokens per step depend on the data: pass actions")
        trajectories = as_trajectory_list(actions, self.action_dim)
        n_tokens = sum(len(t) for traj in trajectories
                       for t in self.encode_tokens(self._blocked_chunks(traj[None])[0]))
        return n_tokens / sum(len(t) for t in trajectories)
