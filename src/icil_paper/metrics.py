"""Smoothness scores of latent trajectories, codebook statistics and empirical Lipschitz constants.

The paper scores a tokenizer by the "least energy" of the latent trajectory it produces for
an action trajectory (Table III; Horn 1983), computed in its code as

    least_energy(z) = sum_t ||z[t+2] - 2 z[t+1] + z[t]||^2          (z shaped (T, D))

the energy of the discrete second difference (acceleration): 0 for a constant-velocity
line, larger the more the curve bends or changes speed. It scales with the square of the
latent scale: 10 z scores 100 times z. A Lipschitz bound shrinks the latent scale, so part
of a low least energy can be scale rather than shape. Two scale-free scores separate the
two (both give z and 10 z the same value):

- `least_energy_normalized`: the least energy of the curve rescaled to unit mean squared
  step length (it changes speed/direction relative to how far it moves per step);
- `curvature_energy`: Horn's discrete curve energy, squared turning angles over segment
  lengths, times the curve's length (a dimensionless bending energy).

Every function accepts a NumPy array or a torch tensor shaped (T, D), or (T,) for a single
dimension, and returns a Python float.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np


def _as_curve(z) -> np.ndarray:
    """(T, D) or (T,) array/tensor -> float64 array (T, D); ValueError for other shapes/NaN."""
    if hasattr(z, "detach"):
        z = z.detach().cpu().numpy()
    z = np.asarray(z, dtype=np.float64)
    if z.ndim == 1:
        z = z[:, None]
    if z.ndim != 2:
        raise ValueError(f"a latent trajectory must be shaped (T, D) or (T,), got {z.shape}")
    if not np.isfinite(z).all():
        raise ValueError("the latent trajectory contains NaN or inf values")
    return z


def least_energy(z) -> float:
    """The paper's smoothness score: sum_t ||z[t+2] - 2 z[t+1] + z[t]||^2 over z (T, D).

    Lower is smoother. 0 for fewer than 3 points. For x_t = t^2 (one dimension, T points)
    every second difference is 2, so the score is 4 (T - 2).
    """
    z = _as_curve(z)
    if len(z) < 3:
        return 0.0
    accel = z[2:] - 2 * z[1:-1] + z[:-2]  # (T-2, D)
    return float(np.sum(accel**2))


def least_energy_normalized(z) -> float:
    """Least energy of z rescaled to unit mean squared step length; scale-free.

        least_energy(z) / mean_t ||z[t+1] - z[t]||^2

    Why the mean squared step length: a second difference measures how much a step differs
    from the previous one, so the natural unit to measure it in is the step itself. Dividing
    by the mean squared step removes the latent scale (z -> s z multiplies both by s^2)
    and keeps what a smoothness score should see: changes of direction and speed relative
    to the motion. Normalizing by the variance of z instead would reward a curve that moves
    in tiny jittery steps inside a wide range. The score is 0 for uniform motion along a
    line and, since ||d2 - d1||^2 <= 2 ||d1||^2 + 2 ||d2||^2, at most 4 (T - 1) (a curve that
    reverses at every step). A motionless curve (all steps zero) scores 0.
    """
    z = _as_curve(z)
    if len(z) < 3:
        return 0.0
    steps = np.diff(z, axis=0)
    mean_sq_step = float(np.mean(np.sum(steps**2, axis=1)))
    if mean_sq_step <= 1e-300:
        return 0.0
    return least_energy(z) / mean_sq_step


def _distinct_points(z: np.ndarray, rel_tol: float = 1e-7) -> np.ndarray:
    """Drop points that repeat their predecessor (up to rel_tol times the curve's extent)."""
    extent = float(np.max(np.abs(z - z[0]))) if len(z) else 0.0
    if extent == 0.0:
        return z[:1]
    keep = [0]
    for i in range(1, len(z)):
        if np.max(np.abs(z[i] - z[keep[-1]])) > rel_tol * extent:
            keep.append(i)
    return z[keep]


def curvature_energy(z) -> float:
    """Horn's discrete curve energy, made scale-free: L * sum_i theta_i^2 / l_i.

    For a polygon through the latent points, theta_i is the turning angle at vertex i (the
    angle between the incoming and outgoing segments) and l_i = (|s_{i-1}| + |s_i|) / 2 the
    length the vertex stands for; theta_i / l_i is the discrete curvature, so
    sum_i theta_i^2 / l_i approximates Horn's (1983) energy, the integral of squared
    curvature along the curve. That integral has units of 1 / length (a circle of radius r
    has 2 pi / r), so it is multiplied by the polygon's total length L to be scale-free:
    z and 10 z give the same value, a straight line 0, a full circle 4 pi^2 whatever its
    radius. Turning angles are taken in D dimensions as 2 atan2(|a - b|, |a + b|) for the
    unit segment directions a and b (accurate for small and large angles).

    Repeated consecutive points (a quantized latent often stays on one code for several
    steps) have no direction; they are merged first, so only the path between distinct
    latents counts. Fewer than 3 distinct points score 0.
    """
    points = _distinct_points(_as_curve(z))
    if len(points) < 3:
        return 0.0
    seg = np.diff(points, axis=0)  # (n-1, D)
    lengths = np.linalg.norm(seg, axis=1)  # (n-1,)
    unit = seg / lengths[:, None]
    a, b = unit[:-1], unit[1:]
    theta = 2 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))
    vertex_length = 0.5 * (lengths[:-1] + lengths[1:])
    return float(np.sum(theta**2 / vertex_length) * lengths.sum())


SMOOTHNESS_SCORES: dict[str, Callable] = {
    "least_energy": least_energy,
    "least_energy_normalized": least_energy_normalized,
    "curvature_energy": curvature_energy,
}


def smoothness_scores(z) -> dict[str, float]:
    """All three smoothness scores of one latent trajectory z (T, D)."""
    return {name: fn(z) for name, fn in SMOOTHNESS_SCORES.items()}


def codebook_usage(ids, codebook_size: int) -> dict[str, float]:
    """Usage and perplexity of discrete codes.

    ids: integer codes in [0, codebook_size), any shape (flattened). Returns
    `usage` (distinct codes seen / codebook_size), `perplexity` (exp of the entropy of the
    empirical code distribution: the number of equally used codes with the same entropy)
    and `codes_used`.
    """
    if hasattr(ids, "detach"):
        ids = ids.detach().cpu().numpy()
    ids = np.asarray(ids).ravel().astype(np.int64)
    if ids.size == 0:
        raise ValueError("no codes to count")
    if ids.min() < 0 or ids.max() >= codebook_size:
        raise ValueError(f"codes must lie in [0, {codebook_size}), got {ids.min()}..{ids.max()}")
    counts = np.bincount(ids, minlength=codebook_size)
    p = counts[counts > 0] / ids.size
    return {"usage": float((counts > 0).sum() / codebook_size),
            "perplexity": float(math.exp(-np.sum(p * np.log(p)))),
            "codes_used": int((counts > 0).sum())}


def empirical_lipschitz(fn: Callable, x, n_pairs: int = 1000, radius: float = 0.1,
                        seed: int = 0, ord: float = math.inf) -> float:
    """Largest ||fn(x1) - fn(x2)|| / ||x1 - x2|| over random pairs near the points x.

    x: tensor (N, A) of anchor points; each pair is an anchor and the anchor plus a uniform
    perturbation in [-radius, radius]^A, plus as many pairs of two random anchors. `ord` is
    the vector norm (inf: the paper's choice). A lower estimate of the true constant.
    """
    import torch

    x = torch.as_tensor(x, dtype=torch.float32)
    gen = torch.Generator().manual_seed(seed)
    idx = torch.randint(len(x), (n_pairs,), generator=gen)
    x1 = x[idx]
    near = x1 + radius * (2 * torch.rand(x1.shape, generator=gen) - 1)
    far = x[torch.randint(len(x), (n_pairs,), generator=gen)]
    a = torch.cat([x1, x1])
    b = torch.cat([near, far])
    with torch.no_grad():
        num = torch.linalg.vector_norm(fn(a) - fn(b), ord=ord, dim=-1)
    den = torch.linalg.vector_norm(a - b, ord=ord, dim=-1)
    valid = den > 1e-9
    return float((num[valid] / den[valid]).max()) if valid.any() else 0.0


def ascending(values: Mapping[str, float]) -> list[str]:
    """Keys ordered by value, smallest first (for smoothness scores: smoothest first)."""
    return sorted(values, key=values.get)


def rank_correlation(a: Mapping[str, float], b: Mapping[str, float]) -> float:
    """Spearman rank correlation over the keys two score tables share (ties share ranks)."""
    from scipy.stats import spearmanr

    keys = sorted(set(a) & set(b))
    if len(keys) < 2:
        raise ValueError(f"rank correlation needs at least 2 shared keys, got {keys}")
    return float(spearmanr([a[k] for k in keys], [b[k] for k in keys]).statistic)
