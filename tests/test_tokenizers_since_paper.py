"""The tokenizers that came after the paper: FSQ's grid, residual VQ's levels, B-spline
round trips, and Eq. 4's bound on every `lip*` variant."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.data.trajectories import generate_trajectories
from icil_paper.metrics import empirical_lipschitz
from icil_paper.seeding import seed_everything
from icil_paper.tokenizers import lipschitz_layers, lipschitz_loss, make_tokenizer
from icil_paper.tokenizers.base import causal_chunks
from icil_paper.tokenizers.configs import (
    SINCE_PAPER,
    BSplineConfig,
    FSQConfig,
    LipFSQConfig,
    LipRVQConfig,
    LipschitzOptions,
    RVQConfig,
)
from icil_paper.tokenizers.training import evaluate_tokenizer, train_tokenizer

A = 7


@pytest.fixture(scope="module")
def trajectories() -> list[np.ndarray]:
    return generate_trajectories(16, seed=0, noise=0.02)


def _batch(trajectories, b=4, t=20) -> torch.Tensor:
    return torch.from_numpy(np.stack([tr[:t] for tr in trajectories[:b]])).float()


def _trained(config, trajectories, steps=150):
    seed_everything(0)
    tok = make_tokenizer(config, A)
    study = dataclasses.replace(get_preset("smoke").tokenizer_study, steps=steps, batch_size=32,
                                window=8, lr=3e-3)
    train_tokenizer(tok, trajectories, study, seed=0, progress=False)
    return tok


def test_every_later_tokenizer_is_registered_with_its_lip_variant():
    from icil_paper.tokenizers import TOKENIZERS

    assert TOKENIZERS[-len(SINCE_PAPER):] == SINCE_PAPER
    for plain, lip in (("fsq", "lipfsq"), ("rvq", "liprvq")):
        a, b = make_tokenizer(plain, A), make_tokenizer(lip, A)
        assert type(b).__mro__[1] is type(a)  # the same class, Eq. 4 on
        assert not lipschitz_layers(a.encoder)
        n_linear = sum(isinstance(m, torch.nn.Linear) for m in a.encoder.modules())
        assert len(lipschitz_layers(b.encoder)) == n_linear == len(a.config.hidden) + 1


# ----------------------------------------------------------------------- FSQ
@pytest.mark.parametrize("levels", [(8, 5, 5, 5), (4, 4, 4), (7, 6)])
def test_fsq_codes_lie_on_its_grid(levels, trajectories):
    tok = make_tokenizer(FSQConfig(latent_dim=16, levels=levels), A).train()
    x = _batch(trajectories)
    with torch.no_grad():
        tok.encoder[-1].weight.mul_(20)  # spread the latents over every level
    out = tok(x)
    q, codes = tok.quantize(out.latents)
    assert codes.shape == x.shape[:2] and codes.dtype == torch.long
    assert 0 <= codes.min() and codes.max() < math.prod(levels) == tok.codebook_size
    for dim in range(len(levels)):
        grid = tok.grid_values(dim)
        assert len(grid) == levels[dim]
        gap = (q[..., dim, None] - grid).abs().amin(-1)  # distance to the nearest grid value
        assert gap.max() < 1e-6, dim
    assert torch.equal(q, tok.codes_to_grid(codes))
    assert torch.equal(out.embeddings, tok.embed_codes(codes))  # what the policy reads


@pytest.mark.parametrize("levels", [(8, 5, 5, 5), (4, 4, 4), (7, 6)])
def test_fsq_round_trip_is_exact_on_grid_points(levels):
    tok = make_tokenizer(FSQConfig(latent_dim=16, levels=levels), A)
    codes = torch.arange(tok.codebook_size)
    grid = tok.codes_to_grid(codes)  # every grid point, (K, d)
    assert len(torch.unique(grid, dim=0)) == tok.codebook_size
    assert torch.equal(tok.grid_to_codes(grid), codes)
    assert torch.equal(tok.codes_to_grid(tok.grid_to_codes(grid)), grid)
    # Each grid point's preimage under FSQ's bound quantizes back to exactly that point.
    q, again = tok.quantize(_preimage(grid, levels)[None])
    assert torch.equal(again[0], codes) and torch.equal(q[0], grid)
    # Every level of every dimension is reached by a sweep of the encoder's output.
    sweep = torch.linspace(-6, 6, 2001)[:, None].expand(-1, len(levels)).contiguous()
    q, _ = tok.quantize(sweep[None])
    for dim in range(len(levels)):
        assert torch.equal(torch.unique(q[0, :, dim]), tok.grid_values(dim))


def _preimage(grid: torch.Tensor, levels) -> torch.Tensor:
    """z with tanh(z + shift) * half_l - offset = grid * floor(L / 2): FSQ's bound inverted
    (Mentzer et al. 2023, Appendix A.1; eps = 1e-3)."""
    L = torch.tensor(levels, dtype=torch.float64)
    half_l = (L - 1) * (1 + 1e-3) / 2
    offset = torch.where(L % 2 == 0, 0.5, 0.0)
    shift = torch.atanh(offset / half_l)
    target = grid.double() * torch.floor(L / 2)
    return (torch.atanh((target + offset) / half_l) - shift).float()


def test_fsq_refuses_levels_below_three():
    with pytest.raises(ValueError, match="at least 3"):
        make_tokenizer(FSQConfig(levels=(8, 2)), A)


# ----------------------------------------------------------------------- residual VQ
@pytest.mark.parametrize("config", [RVQConfig(latent_dim=16, num_quantizers=4, codebook_size=16),
                                    LipRVQConfig(latent_dim=16, num_quantizers=3,
                                                 codebook_size=8)], ids=["rvq", "liprvq"])
def test_residual_vq_error_falls_with_each_level(config, trajectories):
    tok = _trained(config, trajectories)
    x = _batch(trajectories, b=8, t=60)
    errors = tok.level_errors(x)
    assert len(errors) == config.num_quantizers
    assert all(b < a for a, b in zip(errors, errors[1:], strict=False)), errors
    # The tokenizer's quantized latent is the sum over all its levels.
    with torch.no_grad():
        out = tok.eval()(x)
        z_e = tok.encoder(x)
    assert float(((z_e - out.embeddings) ** 2).mean()) == pytest.approx(errors[-1], rel=1e-4)
    assert out.codes.shape == (*x.shape[:2], config.num_quantizers)


def test_residual_vq_reports_the_codes_used_per_level(trajectories):
    tok = _trained(RVQConfig(latent_dim=16, num_quantizers=2, codebook_size=8), trajectories, 40)
    metrics = evaluate_tokenizer(tok, trajectories[:4], timing=False)
    per_level = metrics["codes_used_per_level"]
    assert len(per_level) == 2 and all(1 <= n <= 8 for n in per_level)
    codes = torch.cat([tok(torch.from_numpy(t[None]).float()).codes[0] for t in trajectories[:4]])
    assert per_level == [len(torch.unique(codes[:, level])) for level in range(2)]
    assert metrics["codes_used"] == sum(per_level)  # ids are offset per level
    assert metrics["codebook_size"] == 16
    assert evaluate_tokenizer(make_tokenizer("vq", A), trajectories[:2],
                              timing=False)["codes_used_per_level"] is None


# ----------------------------------------------------------------------- B-splines
def _cubic_chunks(n: int, chunk: int, seed: int = 0) -> np.ndarray:
    """(n, chunk, A) chunks whose every dimension is a random cubic polynomial of time."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, chunk)
    coef = rng.uniform(-1, 1, size=(n, 4, A))
    return np.einsum("pk,nka->npa", s[:, None] ** np.arange(4), coef)


@pytest.mark.parametrize("chunk,k", [(8, 4), (8, 5), (12, 8), (16, 16)])
def test_bspline_round_trip_of_a_cubic_is_exact_up_to_quantization(chunk, k):
    chunks = _cubic_chunks(30, chunk)
    tok = make_tokenizer(BSplineConfig(latent_dim=8, chunk=chunk, control_points=k, n_bins=64),
                         A).fit(list(chunks))
    points = tok.control_points_of(torch.from_numpy(chunks))
    assert torch.allclose(tok.evaluate(points), torch.from_numpy(chunks), atol=1e-9)  # fit
    decoded = tok.decode_codes(tok.encode_chunks(chunks)).numpy()
    error = np.abs(decoded - chunks).max(axis=(0, 1))  # (A,)
    half_bin = tok.bin_width.numpy() / 2
    assert (error <= half_bin + 1e-9).all()
    assert (error > 0).any()  # 64 bins do quantize
    # the least-squares fit is scipy's
    from scipy.interpolate import make_lsq_spline

    from icil_paper.tokenizers.bspline import clamped_knots

    s = np.linspace(0, 1, chunk)
    ref = make_lsq_spline(s, chunks[0, :, 2], clamped_knots(k), k=3).c
    np.testing.assert_allclose(points[0, :, 2].numpy(), ref, atol=1e-10)


def test_bspline_error_falls_as_control_points_grow():
    s = np.linspace(0.0, 1.0, 16)
    rng = np.random.default_rng(0)
    freq, phase = rng.uniform(2, 6, size=(20, 1, A)), rng.uniform(0, 6, size=(20, 1, A))
    chunks = np.sin(freq * s[None, :, None] + phase)  # smooth, not polynomial
    errors = []
    for k in (4, 6, 8, 10, 12):
        tok = make_tokenizer(BSplineConfig(latent_dim=8, chunk=16, control_points=k,
                                           n_bins=2**16), A).fit(list(chunks))
        decoded = tok.decode_codes(tok.encode_chunks(chunks)).numpy()
        errors.append(float(((decoded - chunks) ** 2).mean()))
    assert all(b < 0.5 * a for a, b in zip(errors, errors[1:], strict=False)), errors


def test_bspline_step_embedding_ignores_future_actions(trajectories):
    tok = make_tokenizer(BSplineConfig(latent_dim=8, chunk=6, control_points=4, n_bins=32),
                         A).fit(trajectories)
    x = _batch(trajectories, b=1, t=20)
    changed = x.clone()
    changed[:, 12:] += 0.3
    out, out_changed = tok(x), tok(changed)
    assert torch.equal(out.embeddings[:, :12], out_changed.embeddings[:, :12])
    assert not torch.equal(out.embeddings[:, 12:], out_changed.embeddings[:, 12:])
    # the last step's embedding needs only its context, as a policy feeds it at inference
    tail = tok(x[:, -tok.context_steps:]).embeddings[:, -1]
    assert torch.equal(out.embeddings[:, -1], tail)
    # reconstruction: the decoded chunk ending at each step, at that step
    chunks = causal_chunks(x.double(), tok.chunk)[0]  # (T, C, A)
    decoded = tok.decode_codes(tok.encode_chunks(chunks))[:, -1]
    np.testing.assert_allclose(out.reconstruction[0].numpy(), decoded.numpy(), atol=1e-6)
    assert tok.tokens_per_step() == pytest.approx(4 * A / 6)


def test_bspline_refuses_bad_sizes_and_unfitted_use():
    with pytest.raises(ValueError, match="control_points"):
        make_tokenizer(BSplineConfig(chunk=4, control_points=5), A)
    with pytest.raises(ValueError, match="control_points"):
        make_tokenizer(BSplineConfig(chunk=8, control_points=3), A)
    with pytest.raises(RuntimeError, match="fit"):
        make_tokenizer(BSplineConfig(), A)(torch.zeros(1, 8, A))


# ----------------------------------------------------------------------- Eq. 4
LIP_VARIANTS = {
    "lipfsq": LipFSQConfig(latent_dim=16, levels=(4, 4, 4)),
    "liprvq": LipRVQConfig(latent_dim=16, num_quantizers=2, codebook_size=8),
    # bounds that bind from the start (softplus(0.2) = 0.80 per layer)
    "lipfsq, c_l init 0.2": LipFSQConfig(latent_dim=16, levels=(4, 4, 4),
                                         lipschitz=LipschitzOptions(c_init=0.2)),
    "liprvq, c_l init 0.2": LipRVQConfig(latent_dim=16, num_quantizers=2, codebook_size=8,
                                         lipschitz=LipschitzOptions(c_init=0.2)),
}


@pytest.mark.parametrize("name", LIP_VARIANTS)
def test_lipschitz_variants_satisfy_eq4s_bound(name, trajectories):
    config = LIP_VARIANTS[name]
    tok = _trained(config, trajectories, steps=60)
    bound = lipschitz_loss(tok.encoder).item()  # prod_l softplus(c_l)
    for layer in lipschitz_layers(tok.encoder):  # Eq. 4: every row sum at most its bound
        row_sums = layer.normalized_weight().abs().sum(dim=1)
        assert (row_sums <= layer.lipschitz_bound() + 1e-5).all()
    anchors = torch.from_numpy(np.concatenate(trajectories)).float()
    for radius in (1e-2, 1e-1, 1.0):
        measured = empirical_lipschitz(tok.encoder, anchors, n_pairs=3000, radius=radius)
        assert 0 < measured <= bound * (1 + 1e-5), (radius, measured, bound)
    out = tok.train()(_batch(trajectories))
    gamma = config.lipschitz.weight
    assert out.losses["lipschitz"].item() == pytest.approx(gamma * bound, rel=1e-5)
    if config.lipschitz.c_init is not None:  # the bound binds: some rows are rescaled
        capped = sum(int((layer.weight.abs().sum(1) > layer.lipschitz_bound()).sum())
                     for layer in lipschitz_layers(tok.encoder))
        assert capped > 0


@pytest.mark.parametrize("name", SINCE_PAPER)
def test_preset_configs_build_at_every_preset(name, trajectories):
    for preset in ("smoke", "small", "reference", "full"):
        config = get_preset(preset).tokenizers.get(name)
        assert config.type == name
        tok = make_tokenizer(config, A).fit(trajectories)
        out = tok(_batch(trajectories, b=2, t=10))
        assert out.embeddings.shape == (2, 10, config.latent_dim)


# ----------------------------------------------------------------------- the table
def test_the_beyond_table_reuses_table_is_cells_and_plans_five_seeds_for_the_reference():
    from icil_paper.paper import table_spec
    from icil_paper.tables.cells import plan

    preset = get_preset("reference")
    beyond, table1 = table_spec(preset, "beyond"), table_spec(preset, "I")
    assert [r.label for r in beyond.rows] == ["icrt+vq", "icrt+lipvq", "icrt+fsq",
                                               "icrt+lipfsq", "icrt+rvq", "icrt+liprvq",
                                               "icrt+bspline"]
    for row in beyond.rows:  # Table I's rows keep all of Table I's seeds
        want = preset.tables.icrt_seeds if row.label in ("icrt+vq", "icrt+lipvq") else 5
        assert {c.seeds for c in row.entries.values()} == {want}, row.label
        assert row.entries["features"].units[0].features is not None
    t1_units = {(u.run.key(), u.eval) for u in table1.units()}
    for name in ("icrt+vq", "icrt+lipvq"):
        shared = {(u.run.key(), u.eval) for u in beyond.row(name).entries["avg"].units}
        t1 = {(u.run.key(), u.eval) for u in table1.row(name).entries["avg"].units}
        assert t1 == shared  # Table I's seeds (10, more than 5), evaluated on the same episodes
    assert not {(u.run.key(), u.eval) for u in beyond.row("icrt+fsq").entries["avg"].units} \
        & t1_units
    both = plan([table1, beyond])
    assert len(both) == len(plan([table1])) + 5 * 5  # the five new rows only


def test_the_beyond_table_is_a_reproduce_stage_and_prints(capsys):
    from icil_paper.cli import main
    from icil_paper.reproduce import STAGES

    assert "table-beyond" in [s.name for s in STAGES]
    assert main(["tables", "--preset", "smoke", "--table", "beyond"]) == 0
    out = capsys.readouterr().out
    assert "Tokenizers since the paper" in out and "icrt+liprvq" in out and "not run" in out
    assert "0.530" in out  # Table I's LipVQ-VAE number, the paper's
