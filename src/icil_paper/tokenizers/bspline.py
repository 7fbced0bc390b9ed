"""`bspline`: B-spline control points of action chunks, BEAST style (Zhou et al. 2025).

Per chunk of C steps (C, A), each action dimension is fitted by a clamped cubic B-spline with
K control points over the chunk's time s in [0, 1]:

    basis    Phi (C, K), Phi[i, k] = B_k(s_i), s_i = i / (C - 1)   (`BSpline.design_matrix`)
    fit      P = pinv(Phi) chunk                                   (K, A) least squares
    quantize codes = round((P - low_a) / (high_a - low_a) * (n_bins - 1))   in [0, n_bins)
    decode   chunk_hat = Phi dequantize(codes)                     (C, A)

low_a / high_a: the range of dimension a's control points over the training chunks (`fit`).
Since B_k >= 0 and sum_k B_k = 1, the decoded error per dimension is at most
(high_a - low_a) / (2 (n_bins - 1)), and a cubic chunk is fitted exactly.

One embedding per step, as `fast`: step t is the chunk of the C actions ending at t; its
K * A tokens' learned embeddings are averaged. `decode(embeddings)` is a learned MLP head.

Deviations from BEAST: plain least squares instead of its ridge fit; a chunk ending at every
step, so no continuity constraint between chunks; ranges fitted once per dimension.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput, causal_chunks
from icil_paper.tokenizers.configs import BSplineConfig, register_tokenizer_model

DEGREE = 3
"""Cubic B-splines (BEAST's released default)."""


def clamped_knots(control_points: int, degree: int = DEGREE) -> np.ndarray:
    """The uniform clamped knot vector of a B-spline with `control_points` coefficients on [0, 1]."""
    inner = np.linspace(0.0, 1.0, control_points - degree + 1)
    return np.concatenate([np.zeros(degree), inner, np.ones(degree)])


def basis_matrix(samples: int, control_points: int, degree: int = DEGREE) -> np.ndarray:
    """Phi (samples, control_points): each basis function at s_i = i / (samples - 1)."""
    from scipy.interpolate import BSpline

    s = np.linspace(0.0, 1.0, samples)
    return BSpline.design_matrix(s, clamped_knots(control_points, degree), degree).toarray()


@register_tokenizer_model("bspline")
class BSplineTokenizer(ActionTokenizer):
    """Quantized B-spline control points of causal action chunks (BSplineConfig)."""

    name = "bspline"
    discrete = True
    needs_fit = True

    def __init__(self, config: BSplineConfig, action_dim: int):
        super().__init__(config, action_dim)
        chunk, k, n_bins = config.chunk, config.control_points, config.n_bins
        self.chunk, self.control_points, self.n_bins = int(chunk), int(k), int(n_bins)
        phi = basis_matrix(chunk, k)
        self.register_buffer("basis", torch.from_numpy(phi), persistent=False)  # (C, K)
        self.register_buffer("fit_matrix", torch.from_numpy(np.linalg.pinv(phi)),
                             persistent=False)  # (K, C)
        self.register_buffer("low", torch.full((action_dim,), -1.0, dtype=torch.float64))
        self.register_buffer("high", torch.full((action_dim,), 1.0, dtype=torch.float64))
        n_tokens = k * action_dim
        self.embedding = nn.Embedding(n_tokens * n_bins, config.latent_dim)
        self.decoder = mlp([config.latent_dim, *config.hidden[::-1], action_dim])
        # Token id of bin b of (control point k, dimension a) is (k * A + a) * n_bins + b.
        self.register_buffer("offsets", (torch.arange(n_tokens) * n_bins).view(k, action_dim),
                             persistent=False)

    # ------------------------------------------------------------------ fitting
    def _fit(self, trajectories: list[np.ndarray]) -> None:
        points = torch.cat([self.control_points_of(causal_chunks(
            torch.from_numpy(t)[None], self.chunk))[0] for t in trajectories])  # (N, K, A)
        self._set_range(points.amin(dim=(0, 1)), points.amax(dim=(0, 1)))

    @property
    def bin_width(self) -> Tensor:
        """(A,) the distance between neighbouring bin values of each dimension."""
        return (self.high - self.low) / (self.n_bins - 1)

    # ------------------------------------------------------------------ chunks
    def control_points_of(self, chunks: Tensor) -> Tensor:
        """Least-squares control points (..., K, A) of chunks (..., C, A), float64."""
        return self.fit_matrix @ chunks.to(self.fit_matrix)

    def quantize(self, points: Tensor) -> Tensor:
        """Control points (..., K, A) -> integer bins (..., K, A) LongTensor in [0, n_bins)."""
        scaled = (points - self.low) / self.bin_width
        return scaled.round().clamp(0, self.n_bins - 1).long()

    def dequantize(self, codes: Tensor) -> Tensor:
        """Bins (..., K, A) -> control point values (..., K, A), float64."""
        return self.low + codes.to(self.low.dtype) * self.bin_width

    def evaluate(self, points: Tensor) -> Tensor:
        """The spline of control points (..., K, A) at the chunk's C samples: (..., C, A)."""
        return self.basis @ points

    def encode_chunks(self, chunks) -> Tensor:
        """Action chunks (N, C, A) -> codes (N, K, A) (BEAST's discrete tokens)."""
        chunks = torch.as_tensor(np.asarray(chunks) if not isinstance(chunks, Tensor) else chunks)
        if chunks.ndim != 3 or tuple(chunks.shape[1:]) != (self.chunk, self.action_dim):
            raise ValueError(f"chunks must be shaped (N, {self.chunk}, {self.action_dim}), got "
                             f"{tuple(chunks.shape)}")
        if not torch.isfinite(chunks).all():
            raise ValueError("chunks contain NaN or inf values")
        return self.quantize(self.control_points_of(chunks))

    def decode_codes(self, codes: Tensor) -> Tensor:
        """Codes (N, K, A) -> decoded chunks (N, C, A), float64."""
        return self.evaluate(self.dequantize(codes))

    # ------------------------------------------------------------------ forward
    def _forward(self, actions: Tensor) -> TokenizerOutput:
        b, t, a = actions.shape
        chunks = causal_chunks(actions.to(self.basis.dtype), self.chunk)  # (B, T, C, A)
        codes = self.quantize(self.control_points_of(chunks))  # (B, T, K, A)
        tokens = self.embedding(codes + self.offsets)  # (B, T, K, A, D)
        z = tokens.mean(dim=(2, 3))  # (B, T, D)
        # the decoded spline at the chunk's last sample: step t itself
        recon = (self.basis[-1] @ self.dequantize(codes)).to(actions.dtype)  # (B, T, A)
        return TokenizerOutput(embeddings=z, reconstruction=recon,
                               codes=codes.reshape(b, t, -1), losses=self.decode_losses(z, actions))

    # ------------------------------------------------------------------ facts
    @property
    def context_steps(self) -> int:
        """`chunk`: step t depends on steps t - chunk + 1 .. t."""
        return self.chunk

    @property
    def codebook_size(self) -> int:
        """K * A * n_bins distinct tokens (one vocabulary per control point and dimension)."""
        return self.control_points * self.action_dim * self.n_bins

    def vocabulary_ids(self, codes: Tensor) -> Tensor:
        """Codes (B, T, K * A) as token ids in [0, K * A * n_bins), flattened."""
        return (codes + self.offsets.flatten()).flatten()

    def tokens_per_step(self, actions=None) -> float:
        """K * A tokens per chunk of C steps (non-overlapping chunks, BEAST's rate)."""
        return self.control_points * self.action_dim / self.chunk
