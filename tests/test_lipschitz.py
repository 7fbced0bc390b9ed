"""LipschitzLinear (Eq. 5): row sums are capped, small rows untouched, the product bounds the net."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F

from icil_paper.metrics import empirical_lipschitz
from icil_paper.tokenizers import LipschitzLinear, lipschitz_loss, make_tokenizer
from icil_paper.tokenizers.configs import LipVQConfig
from icil_paper.tokenizers.lipschitz_linear import lipschitz_bounds, lipschitz_layers


@pytest.mark.parametrize("seed", range(5))
def test_row_sums_never_exceed_the_bound(seed):
    torch.manual_seed(seed)
    layer = LipschitzLinear(13, 9)
    with torch.no_grad():
        layer.weight.mul_(torch.rand(9, 1) * 20)  # rows of very different sizes
        layer.c.fill_(float(torch.randn(()) * 2))  # bound anywhere from tiny to large
    row_sums = layer.normalized_weight().abs().sum(dim=1)
    assert (row_sums <= F.softplus(layer.c) + 1e-6).all()


def test_small_rows_pass_unchanged():
    torch.manual_seed(0)
    layer = LipschitzLinear(6, 4, c_init=3.0)
    with torch.no_grad():
        layer.weight.copy_(torch.randn(4, 6))
        layer.weight[1] *= 0.01  # absolute row sum far below softplus(3) = 3.05
        layer.weight[3] *= 0.01
    bound = F.softplus(layer.c)
    normalized = layer.normalized_weight()
    small = layer.weight.abs().sum(1) <= bound
    assert small[1] and small[3]
    assert torch.equal(normalized[small], layer.weight[small])
    big = ~small
    assert torch.allclose(normalized[big].abs().sum(1), bound.expand(int(big.sum())))


def test_liu_initialisation_rescales_nothing():
    torch.manual_seed(0)
    layer = LipschitzLinear(32, 16)
    assert torch.allclose(layer.normalized_weight(), layer.weight)
    assert layer.c.item() == pytest.approx(layer.weight.abs().sum(1).max().item())
    std = layer.weight.std().item()
    assert std == pytest.approx(math.sqrt(2 / 32), rel=0.15)


def test_lipschitz_bound_and_loss_are_products():
    net = torch.nn.Sequential(LipschitzLinear(3, 5, c_init=0.5), torch.nn.ReLU(),
                              LipschitzLinear(5, 2, c_init=2.0))
    expected = F.softplus(torch.tensor(0.5)) * F.softplus(torch.tensor(2.0))
    assert torch.allclose(lipschitz_loss(net), expected)
    assert lipschitz_bounds(net) == pytest.approx([float(F.softplus(torch.tensor(x)))
                                                   for x in (0.5, 2.0)])
    assert float(lipschitz_loss(torch.nn.Linear(2, 2))) == 1.0  # empty product
    lipschitz_loss(net).backward()
    assert all(layer.c.grad is not None for layer in lipschitz_layers(net))


def test_per_row_variant_bounds_each_row():
    torch.manual_seed(0)
    layer = LipschitzLinear(8, 4, per_row=True, c_init=1.0, weight_init="randn")
    with torch.no_grad():
        layer.c.copy_(torch.tensor([-1.0, 0.0, 1.0, 2.0]))
    row_sums = layer.normalized_weight().abs().sum(1)
    assert (row_sums <= F.softplus(layer.c) + 1e-6).all()
    assert layer.lipschitz_bound().item() == pytest.approx(F.softplus(torch.tensor(2.0)).item())


def _encoder_bound(tok) -> float:
    return lipschitz_loss(tok.encoder).item()


@pytest.mark.parametrize("seed", range(3))
def test_lipvq_encoder_is_within_its_bound(seed):
    torch.manual_seed(seed)
    tok = make_tokenizer(LipVQConfig(latent_dim=16, codebook_size=32), 7)
    layers = lipschitz_layers(tok.encoder)
    assert len(layers) == 3  # every encoder linear layer is Lipschitz (the paper)
    with torch.no_grad():  # tight bounds so that Eq. 5 actually rescales rows
        for layer in layers:
            layer.c.fill_(float(torch.rand(()) * 2 - 1))
    x = torch.rand(256, 7) * 2 - 1
    bound = _encoder_bound(tok)
    for radius in (1e-3, 0.1, 1.0):
        estimate = empirical_lipschitz(tok.encoder, x, n_pairs=2000, radius=radius, seed=seed)
        assert 0 < estimate <= bound * (1 + 1e-5), (radius, estimate, bound)


def test_lipvq_encoder_within_bound_after_training():
    torch.manual_seed(0)
    tok = make_tokenizer(LipVQConfig(latent_dim=16, codebook_size=32), 7)
    optimizer = torch.optim.Adam(tok.parameters(), lr=1e-2)
    x = torch.rand(64, 4, 7) * 2 - 1
    for _ in range(30):
        loss = tok(x).total_loss()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    estimate = empirical_lipschitz(tok.encoder, x.reshape(-1, 7), n_pairs=2000, radius=0.05)
    assert estimate <= _encoder_bound(tok) * (1 + 1e-5)


def test_gradient_based_worst_case_stays_within_bound():
    """A harder lower estimate than random pairs: ascend the difference quotient."""
    torch.manual_seed(1)
    tok = make_tokenizer(LipVQConfig(latent_dim=16, codebook_size=32), 7)
    with torch.no_grad():
        for layer in lipschitz_layers(tok.encoder):
            layer.c.fill_(0.3)
    bound = _encoder_bound(tok)
    a = (torch.rand(32, 7) * 2 - 1).requires_grad_(True)
    b = (a.detach() + 0.01 * torch.randn(32, 7)).requires_grad_(True)
    optimizer = torch.optim.Adam([a, b], lr=1e-2)
    for _ in range(100):
        ratio = (torch.linalg.vector_norm(tok.encoder(a) - tok.encoder(b), ord=math.inf, dim=-1)
                 / torch.linalg.vector_norm(a - b, ord=math.inf, dim=-1).clamp_min(1e-6))
        optimizer.zero_grad()
        (-ratio.sum()).backward()
        optimizer.step()
    assert ratio.max().item() <= bound * (1 + 1e-5)
