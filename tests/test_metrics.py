"""Smoothness scores, codebook statistics and the empirical Lipschitz estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from icil_paper.metrics import (
    codebook_usage,
    curvature_energy,
    empirical_lipschitz,
    least_energy,
    least_energy_normalized,
    smoothness_scores,
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


def test_least_energy_grows_with_scale_but_normalized_scores_do_not():
    rng = np.random.default_rng(0)
    z = np.cumsum(rng.normal(size=(40, 5)), axis=0)
    assert least_energy(10 * z) == pytest.approx(100 * least_energy(z))
    for score in (least_energy_normalized, curvature_energy):
        assert score(10 * z) == pytest.approx(score(z), rel=1e-9)
        assert score(1e-3 * z) == pytest.approx(score(z), rel=1e-9)


def test_normalized_least_energy_range():
    t = np.arange(30, dtype=float)[:, None]
    assert least_energy_normalized(t * np.ones((1, 3))) == pytest.approx(0.0, abs=1e-12)
    zigzag = np.array([(-1.0) ** i for i in range(30)])[:, None]  # reverses every step
    # Every second difference is 4 (squared 16), every step 2 (squared 4): 16 * 28 / 4.
    assert least_energy_normalized(zigzag) == pytest.approx(4 * 28)
    assert least_energy_normalized(zigzag) <= 4 * (30 - 1)
    assert least_energy_normalized(np.ones((10, 2))) == 0.0  # motionless


def test_curvature_energy_of_a_circle_is_four_pi_squared():
    for radius in (0.01, 1.0, 100.0):
        angles = np.linspace(0, 2 * np.pi, 2001)
        circle = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        assert curvature_energy(circle) == pytest.approx(4 * np.pi**2, rel=1e-3)


def test_curvature_energy_of_a_line_is_zero_and_ignores_repeats():
    t = np.arange(20, dtype=float)[:, None] * np.array([[1.0, 2.0, -1.0]])
    assert curvature_energy(t) == pytest.approx(0.0, abs=1e-6)
    # Repeated points (a quantized latent staying on a code) do not change the score.
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    repeated = np.repeat(square, 3, axis=0)
    assert curvature_energy(repeated) == pytest.approx(curvature_energy(square))
    # Two right-angle turns on unit segments: L * sum theta^2 / l = 3 * 2 * (pi/2)^2.
    assert curvature_energy(square) == pytest.approx(3 * 2 * (np.pi / 2) ** 2)


def test_curvature_energy_prefers_gentle_curves():
    angles = np.linspace(0, np.pi / 2, 50)
    arc = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    rng = np.random.default_rng(0)
    jittery = arc + 0.02 * rng.normal(size=arc.shape)
    assert curvature_energy(jittery) > 10 * curvature_energy(arc)


def test_smoothness_scores_bad_input():
    with pytest.raises(ValueError, match="shaped"):
        least_energy(np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match="NaN"):
        curvature_energy(np.array([[0.0], [np.nan], [1.0]]))
    assert set(smoothness_scores(np.random.default_rng(0).normal(size=(8, 2)))) == {
        "least_energy", "least_energy_normalized", "curvature_energy"}


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
