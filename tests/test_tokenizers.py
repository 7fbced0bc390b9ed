"""Action tokenizers: interface, gradients, learning, FAST round trips, input errors."""

from __future__ import annotations

import dataclasses
import io
import math

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.data.trajectories import generate_trajectories
from icil_paper.registry import UnknownNameError
from icil_paper.seeding import seed_everything
from icil_paper.tokenizers import TOKENIZERS, make_tokenizer
from icil_paper.tokenizers.configs import default_config, lipvq_official
from icil_paper.tokenizers.fast import FastDecodeError
from icil_paper.tokenizers.training import (
    evaluate_tokenizer,
    reconstruction_errors,
    stand_alone,
    train_tokenizer,
)

A, D, K = 7, 16, 64


def cfg(name: str, **fields):
    """Tokenizer `name` at test size (D = 16, K = 64 codes: FSQ's 4 x 4 x 4 grid, residual
    VQ's 8 x 8; FAST's chunk 4 and vocabulary 300, B-spline chunks of 6 steps)."""
    sized = {"latent_dim": D}
    if name in ("vq", "lfq", "lipvq"):
        sized["codebook_size"] = K
    if name == "fast":
        sized.update(vocab_size=300, chunk=4)
    if name in ("fsq", "lipfsq"):
        sized["levels"] = (4, 4, 4)
    if name in ("rvq", "liprvq"):
        sized.update(num_quantizers=2, codebook_size=8)
    if name == "bspline":
        sized.update(chunk=6, control_points=4, n_bins=64)
    return default_config(name, **{**sized, **fields})


# Every tokenizer plus the official code's LipVQ variant.
VARIANTS = [cfg(name) for name in TOKENIZERS] + [lipvq_official(latent_dim=D, codebook_size=K)]
IDS = [*TOKENIZERS, "lipvq-official"]


@pytest.fixture(scope="module")
def trajectories() -> list[np.ndarray]:
    return generate_trajectories(16, seed=0, noise=0.02)


@pytest.fixture(scope="module")
def held_out() -> list[np.ndarray]:
    return generate_trajectories(4, seed=1, noise=0.02)


def _batch(trajectories, b=3, t=12) -> torch.Tensor:
    return torch.from_numpy(np.stack([tr[:t] for tr in trajectories[:b]]))


def _make(config, trajectories):
    seed_everything(0)
    if isinstance(config, str):
        config = cfg(config)
    return make_tokenizer(config, A).fit(trajectories)


def test_registry_lists_every_tokenizer():
    assert TOKENIZERS == ("mlp", "lip-mlp", "bin", "fast", "vq", "lfq", "lipvq",
                          "fsq", "lipfsq", "rvq", "liprvq", "bspline")
    with pytest.raises(UnknownNameError, match="lipvq"):
        make_tokenizer("lipvqq", A)


@pytest.mark.parametrize("config", VARIANTS, ids=IDS)
def test_shapes_and_finite_losses(config, trajectories):
    tok = _make(config, trajectories)
    x = _batch(trajectories)
    out = tok(x)
    assert out.embeddings.shape == (3, 12, D)
    assert out.reconstruction.shape == (3, 12, A)
    assert tok.decode(out.embeddings).shape == (3, 12, A)
    assert out.losses, "every tokenizer reports at least one loss"
    for key, value in out.losses.items():
        assert value.ndim == 0 and torch.isfinite(value), key
    assert torch.isfinite(out.total_loss())
    if tok.discrete:
        assert out.codes is not None and out.codes.dtype == torch.long
        ids = tok.vocabulary_ids(out.codes)
        assert ids.min() >= 0 and ids.max() < tok.codebook_size
    else:
        assert out.codes is None


@pytest.mark.parametrize("name", ["vq", "lfq", "lipvq", "fsq", "lipfsq", "rvq", "liprvq"])
def test_gradients_reach_encoder_through_quantizer(name, trajectories):
    tok = _make(name, trajectories).train()
    out = tok(_batch(trajectories))
    # A policy-like loss on the embeddings alone: only the straight-through path connects it
    # to the encoder.
    (out.embeddings * torch.randn_like(out.embeddings)).sum().backward()
    first = next(m for m in tok.encoder.modules() if hasattr(m, "weight"))
    assert first.weight.grad is not None and first.weight.grad.abs().sum() > 0


def test_official_lipvq_has_no_straight_through(trajectories):
    tok = _make(lipvq_official(latent_dim=D, codebook_size=K), trajectories).train()
    out = tok(_batch(trajectories))
    assert not out.embeddings.requires_grad  # the policy gets the quantized latent detached
    out.losses["reconstruction"].backward()
    first = tok.encoder[0]
    assert first.weight.grad is None or first.weight.grad.abs().sum() == 0
    assert "lipschitz" not in out.losses


def test_vq_embeddings_are_codebook_vectors(trajectories):
    tok = _make("vq", trajectories).train()
    out = tok(_batch(trajectories))
    assert torch.equal(out.embeddings, tok.codebook(out.codes))


@pytest.mark.parametrize("name", ["vq", "lipvq"])
def test_straight_through_sends_no_reconstruction_gradient_to_the_codebook(name, trajectories):
    """VQ-VAE's estimator z_e + sg[z_q - z_e]: the codebook learns from the codebook loss only;
    the `codebook` form z_q + (z_e - sg[z_e]) also passes the decoder's gradient to it."""
    x = _batch(trajectories)
    grads = {}
    for mode in ("vqvae", "codebook"):
        tok = _make(cfg(name, straight_through=mode), trajectories).train()
        out = tok(x)
        assert torch.equal(out.embeddings, tok.codebook(out.codes))  # same value either way
        out.losses["reconstruction"].backward()
        grads[mode] = tok.codebook.weight.grad
        encoder_grad = next(m for m in tok.encoder.modules() if hasattr(m, "weight")).weight.grad
        assert encoder_grad is not None and encoder_grad.abs().sum() > 0, mode
    assert grads["vqvae"] is None or grads["vqvae"].abs().sum() == 0
    assert grads["codebook"] is not None and grads["codebook"].abs().sum() > 0


def test_dead_code_restart_moves_unused_codes_to_encoder_outputs(trajectories):
    tok = _make(cfg("vq", dead_code_restart=2), trajectories).train()
    x = _batch(trajectories)
    before = tok.codebook.weight.detach().clone()
    used = set(tok(x).codes.flatten().tolist())
    tok(x)  # the second step restarts every code unused in both steps
    after = tok.codebook.weight.detach()
    dead = [k for k in range(K) if k not in used]
    assert dead and not torch.equal(after[dead], before[dead])
    z_e = tok.encoder(x).detach().reshape(-1, D)
    gap = (after[dead][:, None] - z_e[None]).abs().amax(-1).amin(-1)  # to the nearest output
    assert torch.all(gap == 0)


def test_codebook_weight_decay_is_an_option():
    from icil_paper.train.optim import make_optimizer

    for decay in (True, False):
        tok = make_tokenizer(cfg("lipvq", codebook_weight_decay=decay), A)
        opt = make_optimizer(tok, 1e-3, 0.1, (0.9, 0.95))
        decayed = {id(p) for g in opt.param_groups if g["weight_decay"] > 0 for p in g["params"]}
        assert (id(tok.codebook.weight) in decayed) is decay


# Threshold per tokenizer on the held-out MSE after training, as a fraction of the actions'
# variance, with room for seed-to-seed variation (measured: mlp 0.01, vq 0.18, lfq 0.25,
# lipvq 0.14, bin head 0.38, fast head 0.45; fsq 0.23, lipfsq 0.16, rvq 0.13, liprvq 0.12,
# bspline head 0.36). For bin, fast and bspline the reconstruction itself is exact up to the
# bin width / rounding (tested separately); the threshold is on the learned decode head.
THRESHOLDS = {"mlp": 0.05, "lip-mlp": 0.05, "vq": 0.4, "lfq": 0.5, "lipvq": 0.4,
              "bin": 0.7, "fast": 0.8, "fsq": 0.45, "lipfsq": 0.4, "rvq": 0.3, "liprvq": 0.3,
              "bspline": 0.7}


@pytest.mark.parametrize("name", TOKENIZERS)
def test_reconstruction_error_falls_below_threshold(name, trajectories, held_out):
    config = dataclasses.replace(get_preset("smoke").tokenizer_study, steps=300, batch_size=32,
                                 window=8, lr=3e-3)
    seed_everything(0)
    tok = make_tokenizer(stand_alone(cfg(name)), A)
    tok.fit(trajectories)
    variance = float(np.concatenate(held_out).var(0).mean())
    key = "decode_mse" if name in ("bin", "fast", "bspline") else "reconstruction_mse"
    before = reconstruction_errors(tok, held_out)[key]
    train_tokenizer(tok, trajectories, config, seed=0, progress=False)
    after = reconstruction_errors(tok, held_out)[key]
    assert after < THRESHOLDS[name] * variance, (name, after / variance)
    assert after < 0.5 * before


def test_bin_reconstruction_within_half_a_bin(trajectories):
    tok = make_tokenizer(cfg("bin", n_bins=256), A).fit(trajectories)
    x = _batch(trajectories, b=4, t=40)
    out = tok(x)
    assert out.codes.shape == (4, 40, A)
    assert (out.codes >= 0).all() and (out.codes < 256).all()
    assert ((out.reconstruction - x).abs() <= tok.bin_width / 2 + 1e-6).all()
    assert tok.tokens_per_step() == A


def test_bin_clips_values_outside_the_fitted_range(trajectories):
    tok = make_tokenizer(cfg("bin", n_bins=16), A).fit(trajectories)
    x = torch.full((1, 2, A), 5.0)
    out = tok(x)
    assert (out.codes == 15).all()


# ----------------------------------------------------------------------- FAST
@pytest.fixture(scope="module")
def fast(trajectories):
    return make_tokenizer(cfg("fast", chunk=8, scale=10.0, vocab_size=400), A).fit(trajectories)


def _chunks(trajectories, n=20, chunk=8):
    rng = np.random.default_rng(0)
    out = []
    for _ in range(n):
        traj = trajectories[int(rng.integers(len(trajectories)))]
        s = int(rng.integers(len(traj) - chunk))
        out.append(traj[s:s + chunk])
    return np.stack(out).astype(np.float64)


def test_fast_round_trips_smooth_chunks_within_its_scale(fast, trajectories):
    chunks = _chunks(trajectories)
    tokens = fast.encode_tokens(chunks)
    decoded, ok = fast.decode_tokens(tokens)
    assert ok.all()
    # Rounding moves each orthonormal DCT coefficient by at most 1 / (2 scale).
    bound = math.sqrt(8 * A) / (2 * fast.scale)
    errors = np.linalg.norm((decoded - chunks).reshape(len(chunks), -1), axis=1)
    assert errors.max() <= bound + 1e-9
    assert np.abs(decoded - chunks).max() <= bound
    # BPE compresses: fewer tokens than the 8 * 7 coefficients of a chunk.
    assert np.mean([len(t) for t in tokens]) < 8 * A


def test_fast_reconstruction_matches_token_decoding(fast, trajectories):
    x = _batch(trajectories, b=2, t=8)
    blocked = make_tokenizer(cfg("fast", chunk=8, vocab_size=400, mode="blocked"), A)
    blocked.load_state_dict(fast.state_dict())
    out = blocked(x)
    decoded, ok = blocked.decode_tokens([fast.encode_tokens(x[i:i + 1].numpy())[0]
                                         for i in range(2)])
    assert ok.all()
    np.testing.assert_allclose(out.reconstruction.numpy(), decoded, atol=1e-5)


def test_fast_causal_embedding_ignores_future_actions(fast, trajectories):
    x = _batch(trajectories, b=1, t=16)
    changed = x.clone()
    changed[:, 10:] += 0.3
    z, z_changed = fast(x).embeddings, fast(changed).embeddings
    assert torch.allclose(z[:, :10], z_changed[:, :10])
    assert not torch.allclose(z[:, 10:], z_changed[:, 10:])


def test_fast_malformed_tokens_are_reported_not_zeroed(fast, trajectories):
    tokens = fast.encode_tokens(_chunks(trajectories, n=3))
    malformed = [tokens[0][:-1], tokens[1] + tokens[1][:1], [fast.bpe_vocab_size + 5], tokens[2]]
    with pytest.raises(FastDecodeError, match="malformed"):
        fast.decode_tokens(malformed)
    decoded, ok = fast.decode_tokens(malformed, strict=False)
    assert ok.tolist() == [False, False, False, True]
    assert np.isnan(decoded[:3]).all() and np.isfinite(decoded[3]).all()


def test_fast_state_dict_carries_the_vocabulary(fast, trajectories):
    buffer = io.BytesIO()
    torch.save(fast.state_dict(), buffer)
    buffer.seek(0)
    loaded = make_tokenizer(cfg("fast", chunk=8, vocab_size=400), A)
    loaded.load_state_dict(torch.load(buffer, weights_only=False))
    chunks = _chunks(trajectories, n=5)
    assert loaded.encode_tokens(chunks) == fast.encode_tokens(chunks)
    assert loaded.fitted


def test_fast_refuses_to_run_unfitted():
    tok = make_tokenizer(cfg("fast"), A)
    with pytest.raises(RuntimeError, match="fit"):
        tok(torch.zeros(1, 8, A))


# ----------------------------------------------------------------------- input errors
@pytest.mark.parametrize("config", VARIANTS, ids=IDS)
def test_wrong_action_dimension_raises(config, trajectories):
    tok = _make(config, trajectories)
    with pytest.raises(ValueError, match="action dimension"):
        tok(torch.zeros(2, 5, A - 1))
    with pytest.raises(ValueError, match="action dimension"):
        make_tokenizer(config, A).fit([np.zeros((10, A + 1))])


@pytest.mark.parametrize("config", VARIANTS, ids=IDS)
def test_nan_input_raises(config, trajectories):
    tok = _make(config, trajectories)
    x = _batch(trajectories).clone()
    x[1, 3, 2] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        tok(x)
    bad = [trajectories[0].copy()]
    bad[0][4, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        make_tokenizer(config, A).fit(bad)


def test_wrong_rank_raises():
    tok = make_tokenizer(cfg("mlp"), A)
    with pytest.raises(ValueError, match=r"\(B, T, A\)"):
        tok(torch.zeros(5, A))


def test_evaluate_tokenizer_reports_every_measurement(trajectories, held_out):
    tok = _make("vq", trajectories)
    metrics = evaluate_tokenizer(tok, held_out, throughput_batch=(4, 8), min_time=0.01)
    for key in ("reconstruction_mse", "usage", "perplexity", "tokens_per_step",
                "encode_actions_per_s", "decode_actions_per_s", "least_energy",
                "least_energy_standardized", "latent_scale"):
        assert key in metrics and np.isfinite(metrics[key]), key
    assert 0 < metrics["usage"] <= 1 and 1 <= metrics["perplexity"] <= K


def test_data_codebook_init_is_opt_in(trajectories):
    seed_everything(0)
    default = make_tokenizer(cfg("lipvq"), A).train()
    before = default.codebook.weight.clone()
    default(_batch(trajectories))
    assert torch.equal(default.codebook.weight, before)
    assert before.abs().max() <= 1.0 / K  # VQ-VAE's uniform initialisation
    tok = make_tokenizer(cfg("lipvq", codebook_init="data"), A).train()
    x = _batch(trajectories)
    tok(x)
    z_e = tok.encoder(x).detach().reshape(-1, D)
    nearest = torch.cdist(tok.codebook.weight.detach(), z_e).min(dim=1).values
    assert nearest.max() < 1e-2 * z_e.norm(dim=1).mean()


def test_fast_last_step_embedding_needs_only_its_context(fast, trajectories):
    x = _batch(trajectories, b=1, t=30)
    full = fast(x).embeddings[:, -1]
    tail = fast(x[:, -fast.context_steps:]).embeddings[:, -1]
    assert torch.allclose(full, tail)


@pytest.mark.parametrize("config", VARIANTS, ids=IDS)
def test_an_empty_batch_is_refused(config, trajectories):
    tok = _make(config, trajectories)
    for shape in ((0, 5, A), (2, 0, A)):
        with pytest.raises(ValueError, match="empty batch"):
            tok(torch.zeros(shape))


def test_fast_token_input_is_checked(fast):
    chunk = np.zeros((1, fast.chunk, A))
    chunk[0, 1, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        fast.encode_tokens(chunk)
    assert fast.encode_tokens(np.zeros((0, fast.chunk, A))) == []
    ids = fast.encode_tokens(np.zeros((1, fast.chunk, A)))
    with pytest.raises(FastDecodeError, match="not a whole number"):
        fast.decode_tokens([[ids[0][0] + 0.5, *ids[0][1:]]])
    with pytest.raises(FastDecodeError, match="not an integer"):
        fast.decode_tokens([["a"]])
    np.testing.assert_allclose(fast.decode_tokens([[float(i) for i in ids[0]]])[0], 0, atol=0.05)
