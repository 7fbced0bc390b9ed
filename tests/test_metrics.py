"""Smoothness scores, codebook statistics and the empirical Lipschitz estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from icil_paper.metrics import (
    codebook_usage,
    empirical_lipschitz,
    least_energy,
    least_energy_standardized,
    smoothness_summary,
    standardized_least_energies,
)


def test_least_energy_of_a_constant_velocity_line_is_zero():
    t = np.arange(50, dtype=float)[:, None]
    z = 0.3 + t * np.array([[1.0, -2.0, 0.5]])
    assert least_energy(z) == pytest.approx(0.0, abs=1e-18)


@pytest.mark.parametrize("T", [3, 10, 57])
def test_least_energy_of_a_parabola(T):
    x = np.arange(T, dtype=float) ** 2  # one dimension, T points
    assert least_energy(x) == pytest.approx(4 * (T - 2))
    assert least_energy(x[:, None]) == pytest.approx(4 * (T - 2))


def test_least_energy_accepts_torch_and_short_curves():
    z = torch.randn(20, 4)
    assert least_energy(z) == pytest.approx(least_energy(z.numpy()), rel=1e-6)
    assert least_energy(np.zeros((2, 3))) == 0.0


def _random_walks(seed=0, n=6, D=5):
    rng = np.random.default_rng(seed)
    return [np.cumsum(rng.normal(size=(int(rng.integers(20, 40)), D)), axis=0) for _ in range(n)]


def test_least_energy_grows_with_scale_but_the_standardized_score_does_not():
    walks = _random_walks()
    assert least_energy(7.3 * walks[0]) == pytest.approx(7.3**2 * least_energy(walks[0]))
    scores, sigma = standardized_least_energies(walks)
    for factor in (7.3, 1e-3, -2.0):
        scaled, scaled_sigma = standardized_least_energies([factor * z for z in walks])
        np.testing.assert_allclose(scaled, scores, rtol=1e-10)
        assert scaled_sigma == pytest.approx(abs(factor) * sigma, rel=1e-12)


def test_standardized_score_ignores_a_shift_of_each_dimension():
    walks = _random_walks(1)
    shift = np.array([[100.0, -3.0, 0.0, 5e4, 1.0]])
    scores, sigma = standardized_least_energies(walks)
    shifted, shifted_sigma = standardized_least_energies([z + shift for z in walks])
    np.testing.assert_allclose(shifted, scores, rtol=1e-6)
    assert shifted_sigma == pytest.approx(sigma, rel=1e-6)


def test_standardized_score_is_least_energy_over_the_squared_set_scale():
    walks = _random_walks(2)
    scores, sigma = standardized_least_energies(walks)
    values = np.concatenate(walks)
    assert sigma == pytest.approx(np.sqrt(np.mean(np.var(values, axis=0))))
    for z, score in zip(walks, scores, strict=True):
        assert score == pytest.approx(least_energy(z) / sigma**2)
        assert least_energy_standardized(z, sigma) == pytest.approx(score)
        assert least_energy_standardized(z, 1.0) == least_energy(z)
    # One array (N, T, D) and a torch tensor give the same as a list.
    stacked = np.stack([z[:20] for z in walks])
    from_array = standardized_least_energies(stacked)
    from_tensor = standardized_least_energies(torch.from_numpy(stacked))
    from_list = standardized_least_energies(list(stacked))
    np.testing.assert_allclose(from_array[0], from_list[0])
    np.testing.assert_allclose(from_tensor[0], from_list[0])
    assert from_array[1] == from_list[1] == from_tensor[1]


def _steps(T, jumps, height=1.0):
    """A one-dimensional piecewise-constant curve alternating 0, h, 0, ... with isolated jumps."""
    z = np.zeros(T)
    for k, t in enumerate(np.linspace(0, T, jumps + 2)[1:-1].astype(int)):
        z[t:] = height * ((k + 1) % 2)
    return z


def test_piecewise_constant_curves_with_more_jumps_score_higher():
    one, three = _steps(40, 1), _steps(40, 3)
    assert np.count_nonzero(np.diff(one)) == 1 and np.count_nonzero(np.diff(three)) == 3
    (s1, s3), sigma = standardized_least_energies([one, three])
    # An isolated jump of height h has second differences +h and -h: 2 h^2 per jump.
    assert s1 == pytest.approx(2 / sigma**2) and s3 == pytest.approx(3 * s1)
    # Bigger jumps of the same number and the same set scale: the same scores.
    (b1, b3), _ = standardized_least_energies([5 * one, 5 * three])
    assert (b1, b3) == (pytest.approx(s1), pytest.approx(s3))


def test_no_spread_scores_zero():
    scores, sigma = standardized_least_energies([np.full((10, 3), 2.5)])
    assert sigma == 0.0 and scores.tolist() == [0.0]
    assert least_energy_standardized(np.ones((5, 2)), 0.0) == 0.0
    with pytest.raises(ValueError, match="scale 0 given for a trajectory that moves"):
        least_energy_standardized(_steps(10, 1), 0.0)


def test_smoothness_summary_reports_raw_standardized_and_scale():
    walks = _random_walks(3)
    summary = smoothness_summary(walks)
    scores, sigma = standardized_least_energies(walks)
    assert summary == {"least_energy": pytest.approx(np.mean([least_energy(z) for z in walks])),
                       "least_energy_standardized": pytest.approx(scores.mean()),
                       "latent_scale": pytest.approx(sigma)}
    assert smoothness_summary(iter(walks)) == summary  # a one-pass iterable is enough


def test_smoothness_scores_bad_input():
    with pytest.raises(ValueError, match="shaped"):
        least_energy(np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match="NaN"):
        least_energy(np.array([[0.0], [np.nan], [1.0]]))
    with pytest.raises(ValueError, match="NaN"):
        standardized_least_energies([np.zeros((4, 2)), np.array([[0.0, np.inf]] * 3)])
    with pytest.raises(ValueError, match="share their width D, got \\[2, 3\\]"):
        standardized_least_energies([np.zeros((4, 2)), np.zeros((4, 3))])
    with pytest.raises(ValueError, match=r"\(N, T, D\), got an array shaped \(4, 2\)"):
        standardized_least_energies(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="no latent trajectories"):
        standardized_least_energies([])
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="latent scale must be a finite number"):
            least_energy_standardized(np.zeros((4, 2)), bad)


def test_codebook_usage_and_perplexity():
    stats = codebook_usage(np.array([0, 1, 2, 3] * 5), codebook_size=8)
    assert stats["usage"] == 0.5 and stats["codes_used"] == 4
    assert stats["perplexity"] == pytest.approx(4.0)
    assert codebook_usage(torch.zeros(10, dtype=torch.long), 4)["perplexity"] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="codes must lie"):
        codebook_usage(np.array([0, 9]), codebook_size=8)


def test_empirical_lipschitz_of_a_linear_map():
    torch.manual_seed(0)
    w = torch.randn(3, 5)
    inf_norm = float(w.abs().sum(1).max())  # the exact constant in the infinity norm
    estimate = empirical_lipschitz(lambda x: x @ w.t(), torch.randn(100, 5), n_pairs=5000)
    assert estimate <= inf_norm + 1e-5
    assert estimate > 0.5 * inf_norm
    two = empirical_lipschitz(lambda x: x @ w.t(), torch.randn(100, 5), ord=2)
    assert two <= float(torch.linalg.matrix_norm(w, ord=2)) + 1e-5
    assert math.isfinite(two)


def test_rank_correlation_and_ascending():
    from icil_paper.metrics import ascending, rank_correlation

    a = {"x": 1.0, "y": 2.0, "z": 3.0}
    assert ascending(a) == ["x", "y", "z"]
    assert rank_correlation(a, {"x": 10, "y": 20, "z": 30, "w": 0}) == pytest.approx(1.0)
    assert rank_correlation(a, {"x": 3, "y": 2, "z": 1}) == pytest.approx(-1.0)
    with pytest.raises(ValueError, match="at least 2 shared keys"):
        rank_correlation(a, {"x": 1})
