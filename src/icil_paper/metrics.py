"""Smoothness scores of latent trajectories, codebook statistics and empirical Lipschitz constants.

The paper scores a tokenizer by the "least energy" of the latent trajectory it produces for
an action trajectory (Table III; Horn 1983), computed in its code as

    least_energy(z) = sum_t ||z[t+2] - 2 z[t+1] + z[t]||^2          (z shaped (T, D))

the energy of the discrete second difference (acceleration): 0 for a constant-velocity
line, larger the more the curve bends or changes speed. It scales with the square of the
latent scale: 10 z scores 100 times z. A Lipschitz bound shrinks the latent scale, so part
of a low least energy can be scale rather than shape.

`least_energy_standardized` removes the scale: it is the least energy of z / sigma, where
sigma is the latent scale of the whole evaluation set, the pooled standard deviation of
every latent value (all trajectories, steps and dimensions) about its dimension's mean:

    sigma^2 = mean over trajectories, steps t and dimensions d of (z[t, d] - mean_d)^2
    least_energy_standardized(z) = least_energy(z) / sigma^2

Multiplying every latent by a constant leaves it unchanged, and so does shifting a
dimension by a constant (second differences and deviations from the mean ignore both).
Because sigma is one number for the set, not one per trajectory, a curve that jumps three
times scores three times one that jumps once between the same values: it measures how much
the curve accelerates relative to how far the latents spread, which is what a comparison
across tokenizers needs. `standardized_least_energies` computes sigma over a set and every
trajectory's score.

Two earlier scale-free scores were retired because they fail as comparisons: the least
energy divided by each trajectory's mean squared step is exactly 2 (T - 1) for any
piecewise-constant latent with isolated jumps, whatever their number or size, so it cannot
rank quantised tokenizers; and a turning-angle curvature energy is dominated by tiny
jitter of continuous latents.

Every per-trajectory function accepts a NumPy array or a torch tensor shaped (T, D), or
(T,) for a single dimension.
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


def _latent_scale(curves: list[np.ndarray]) -> float:
    """Pooled standard deviation of the latent values about each dimension's mean."""
    values = np.concatenate(curves, axis=0)  # (sum of T, D)
    return float(np.sqrt(np.mean((values - values.mean(axis=0)) ** 2)))


def least_energy_standardized(z, scale: float) -> float:
    """Least energy of z / scale: least_energy(z) / scale^2, for z (T, D) and a set's scale.

    `scale` is the latent scale sigma of the evaluation set z belongs to (see
    `standardized_least_energies`, which computes it). With scale 1 this is the paper's
    least energy. A scale of 0 means no latent of the set moves: the score is then 0.
    """
    scale = float(scale)
    if not math.isfinite(scale) or scale < 0:
        raise ValueError(f"the latent scale must be a finite number >= 0, got {scale}")
    energy = least_energy(z)
    if scale == 0.0:
        if energy > 0.0:
            raise ValueError("latent scale 0 given for a trajectory that moves; the scale must "
                             "be the spread of a set that includes it")
        return 0.0
    return energy / scale**2


def _curve_set(trajectories) -> list[np.ndarray]:
    """A set of latent trajectories -> list of float64 (T_i, D) arrays of one width D."""
    if hasattr(trajectories, "detach"):
        trajectories = trajectories.detach().cpu().numpy()
    if isinstance(trajectories, np.ndarray) and trajectories.ndim != 3:
        raise ValueError("a set of latent trajectories must be a sequence of (T, D) arrays or "
                         f"one array (N, T, D), got an array shaped {trajectories.shape}")
    curves = [_as_curve(z) for z in trajectories]
    if not curves:
        raise ValueError("no latent trajectories to score")
    widths = sorted({c.shape[1] for c in curves})
    if len(widths) > 1:
        raise ValueError(f"latent trajectories of one set must share their width D, got {widths}")
    return curves


def standardized_least_energies(trajectories) -> tuple[np.ndarray, float]:
    """Every trajectory's standardized least energy and the set's latent scale sigma.

    trajectories: a sequence of latent trajectories (T_i, D) (lengths may differ, the width
    D may not), or one array (N, T, D). Returns (scores (N,), sigma), sigma the pooled
    standard deviation of all latent values about each dimension's mean. A set with no
    spread (sigma 0) scores 0 throughout.
    """
    curves = _curve_set(trajectories)
    sigma = _latent_scale(curves)
    if sigma <= 1e-300:
        return np.zeros(len(curves)), 0.0
    return np.array([least_energy(c) / sigma**2 for c in curves]), sigma


SMOOTHNESS_SCORES: dict[str, Callable] = {
    "least_energy": least_energy,
}
"""Smoothness scores defined on one trajectory alone (the standardized score needs the set's
scale: use `smoothness_summary` or `standardized_least_energies`)."""


def smoothness_summary(trajectories) -> dict[str, float]:
    """Mean raw and standardized least energy of a set of latent trajectories, and its scale.

    Returns `least_energy` (the paper's score, mean over trajectories),
    `least_energy_standardized` (mean over trajectories) and `latent_scale` (sigma): the
    three numbers to show wherever smoothness is shown.
    """
    curves = _curve_set(trajectories)
    scores, sigma = standardized_least_energies(curves)
    raw = [least_energy(z) for z in curves]
    return {"least_energy": float(np.mean(raw)),
            "least_energy_standardized": float(np.mean(scores)),
            "latent_scale": sigma}


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
