"""Smoothness scores of latent trajectories and of executed motion, codebook statistics and
empirical Lipschitz constants.

Latents (Table III): `least_energy(z) = sum_t ||z[t+2] - 2 z[t+1] + z[t]||^2`, the paper's
score for a latent trajectory z (T, D) (Horn 1983); `standardized_least_energies(set)` divides
it by the set's pooled latent variance, a score comparable across tokenizers.

Motion (what a rollout does), `motion_smoothness(path, actions, dt)`:
- `log_dimensionless_jerk` (LDLJ; Hogan and Sternad 2009) of the end-effector path;
- `sparc` (spectral arc length; Balasubramanian et al. 2012, 2015) of its speed profile;
- `action_second_difference`, the per-step least energy of the executed actions.
Higher LDLJ and SPARC, lower action second difference: smoother.

Inputs are NumPy arrays or torch tensors, (T, D) or (T,); a measure is NaN where it is
undefined (too few steps, no motion, non-finite values).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np


def _as_signal(x, width: int | None, name: str = "a latent trajectory",
               strict: bool = False) -> np.ndarray | None:
    """(T, width) (or (T, D) from (T,)) float64 array, or None where it holds non-finite values
    (ValueError if `strict`)."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1 and width is None:
        x = x[:, None]
    if x.ndim != 2 or (width is not None and x.shape[1] != width):
        shape = f"(T, {width})" if width is not None else "(T, D) or (T,)"
        raise ValueError(f"{name} must be shaped {shape}, got {x.shape}")
    if strict and not np.isfinite(x).all():
        raise ValueError(f"{name} contains NaN or inf values")
    return x if np.isfinite(x).all() else None


def least_energy(z) -> float:
    """The paper's smoothness score: sum_t ||z[t+2] - 2 z[t+1] + z[t]||^2 over z (T, D);
    lower is smoother, 0 for fewer than 3 points."""
    z = _as_signal(z, None, strict=True)
    if len(z) < 3:
        return 0.0
    accel = z[2:] - 2 * z[1:-1] + z[:-2]  # (T-2, D)
    return float(np.sum(accel**2))


def _latent_scale(curves: list[np.ndarray]) -> float:
    """Pooled standard deviation of the latent values about each dimension's mean."""
    values = np.concatenate(curves, axis=0)  # (sum of T, D)
    return float(np.sqrt(np.mean((values - values.mean(axis=0)) ** 2)))


def least_energy_standardized(z, scale: float) -> float:
    """least_energy(z) / scale^2, for z (T, D) and its set's latent scale sigma (0: no
    latent of the set moves, score 0)."""
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
    curves = [_as_signal(z, None, strict=True) for z in trajectories]
    if not curves:
        raise ValueError("no latent trajectories to score")
    widths = sorted({c.shape[1] for c in curves})
    if len(widths) > 1:
        raise ValueError(f"latent trajectories of one set must share their width D, got {widths}")
    return curves


def standardized_least_energies(trajectories) -> tuple[np.ndarray, float]:
    """(scores (N,), sigma) for latent trajectories (T_i, D) or one array (N, T, D): each
    one's least energy / sigma^2, sigma the pooled standard deviation of the set's latents."""
    curves = _curve_set(trajectories)
    sigma = _latent_scale(curves)
    if sigma <= 1e-300:
        return np.zeros(len(curves)), 0.0
    return np.array([least_energy(c) / sigma**2 for c in curves]), sigma


def smoothness_summary(trajectories) -> dict[str, float]:
    """Mean `least_energy`, `least_energy_standardized` and the `latent_scale` of a set."""
    curves = _curve_set(trajectories)
    scores, sigma = standardized_least_energies(curves)
    raw = [least_energy(z) for z in curves]
    return {"least_energy": float(np.mean(raw)),
            "least_energy_standardized": float(np.mean(scores)),
            "latent_scale": sigma}


def codebook_usage(ids, codebook_size: int) -> dict[str, float]:
    """`usage` (distinct codes / codebook_size), `perplexity` (exp of the codes' entropy) and
    `codes_used` of integer codes `ids` in [0, codebook_size), any shape."""
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
    """Largest ||fn(x1) - fn(x2)|| / ||x1 - x2|| over random pairs near and between anchors
    x (N, A), in the `ord` norm: a lower estimate of the Lipschitz constant."""
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


# --------------------------------------------------------------------------- motion smoothness
MOTION_MEASURES = ("ldlj", "sparc", "action_jerk")
"""The motion smoothness of a rollout, as every evaluation record holds it per episode."""
SMOOTHER = {"ldlj": +1, "sparc": +1, "action_jerk": -1}
"""Which way each motion measure is smoother: +1 higher, -1 lower."""
MIN_MOTION_STEPS = 4
"""Positions a path needs for LDLJ and SPARC (one third difference; three speeds)."""
MIN_AMPLITUDE = 1e-6
"""A path within this distance of its first point (metres) did not move: NaN."""
SPARC_PADLEVEL = 4
"""SPARC's zero padding: the spectrum has 2^(ceil(log2 N) + padlevel) points."""
SPARC_CUTOFF_HZ = 10.0
"""SPARC's largest cut-off frequency (Hz)."""
SPARC_AMPLITUDE_THRESHOLD = 0.05
"""SPARC's adaptive cut-off: the highest frequency whose normalised magnitude reaches this."""


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not math.isfinite(dt) or dt <= 0:
        raise ValueError(f"the sampling period dt must be a finite number > 0, got {dt}")
    return dt


def speed_profile(path, dt: float) -> np.ndarray:
    """The speed ||x[t+1] - x[t]|| / dt of a path (T, 3) sampled every `dt` seconds: (T - 1,)."""
    x = _as_signal(path, None, "a path")
    dt = _check_dt(dt)
    if x is None:
        return np.full(max(0, len(np.asarray(path)) - 1), np.nan)
    if len(x) < 2:
        return np.zeros(0)
    return np.linalg.norm(np.diff(x, axis=0), axis=1) / dt


def log_dimensionless_jerk(path, dt: float) -> float:
    """LDLJ of a path (T, 3) of positions sampled every `dt` seconds:
    -ln((t2 - t1)^5 / A^2 * integral |d3x/dt3|^2 dt), A the largest distance from the first
    point. Higher is smoother (a minimum-jerk reach: -ln 720); +inf for zero jerk."""
    dt = _check_dt(dt)
    x = _as_signal(path, 3, "a path")
    if x is None or len(x) < MIN_MOTION_STEPS:
        return math.nan
    amplitude = float(np.max(np.linalg.norm(x - x[0], axis=1)))
    if amplitude < MIN_AMPLITUDE:
        return math.nan
    jerk = np.diff(x, n=3, axis=0) / dt**3  # (T - 3, 3)
    integral = float(np.sum(jerk**2)) * dt
    if integral == 0.0:
        return math.inf
    duration = (len(x) - 1) * dt
    return float(-(5 * math.log(duration) - 2 * math.log(amplitude) + math.log(integral)))


def sparc(speed, dt: float, padlevel: int = SPARC_PADLEVEL, cutoff: float = SPARC_CUTOFF_HZ,
          threshold: float = SPARC_AMPLITUDE_THRESHOLD) -> float:
    """Spectral arc length of a speed profile (T,) sampled every `dt` seconds (Balasubramanian
    et al. 2015): SPARC = -integral_0^{w_c} sqrt((1 / w_c)^2 + (dV^(w) / dw)^2) dw, V^ the
    normalised spectrum. Higher is smoother (a minimum-jerk reach: about -1.40)."""
    dt = _check_dt(dt)
    v = np.asarray(speed.detach().cpu().numpy() if hasattr(speed, "detach") else speed,
                   dtype=np.float64)
    if v.ndim != 1:
        raise ValueError(f"a speed profile must be shaped (T,), got {v.shape}")
    if len(v) < MIN_MOTION_STEPS - 1 or not np.isfinite(v).all():
        return math.nan
    nfft = int(2 ** (math.ceil(math.log2(len(v))) + padlevel))
    freq = np.arange(nfft) / (nfft * dt)  # Hz, 0 .. fs
    magnitude = np.abs(np.fft.fft(v, nfft))
    peak = float(magnitude.max())
    if peak <= 0.0:
        return math.nan
    magnitude = magnitude / peak
    within = freq <= cutoff
    freq, magnitude = freq[within], magnitude[within]
    above = np.flatnonzero(magnitude >= threshold)
    if len(above) == 0 or above[-1] == above[0]:
        return math.nan  # a single frequency: no arc to measure
    freq, magnitude = freq[above[0]:above[-1] + 1], magnitude[above[0]:above[-1] + 1]
    span = freq[-1] - freq[0]
    return float(-np.sum(np.sqrt((np.diff(freq) / span) ** 2 + np.diff(magnitude) ** 2)))


def action_second_difference(actions) -> float:
    """mean_t ||a[t+2] - 2 a[t+1] + a[t]||^2 of executed actions (T, A)."""
    a = _as_signal(actions, None, "actions")
    if a is None or len(a) < 3:
        return math.nan
    accel = a[2:] - 2 * a[1:-1] + a[:-2]  # (T - 2, A)
    return float(np.mean(np.sum(accel**2, axis=1)))


def motion_smoothness(path, actions, dt: float) -> dict[str, float]:  # keys: MOTION_MEASURES
    """One rollout's `ldlj`, `sparc` (of its path (T + 1, 3)) and `action_jerk` (actions (T, A))."""
    return {"ldlj": log_dimensionless_jerk(path, dt),
            "sparc": sparc(speed_profile(path, dt), dt),
            "action_jerk": action_second_difference(actions)}
