"""Policies: the transformer's causality and KV cache, ICRT's token layout and loss mask,
every policy x tokenizer combination on synthetic demonstrations, and clear errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.policies import POLICIES, make_policy
from icil_paper.policies.backbones import HashedTextEmbedding, ResNet18
from icil_paper.policies.base import TemporalEnsemble
from icil_paper.policies.batching import DemoSet, as_obs_spec, prompt_query_batch
from icil_paper.policies.inspection import token_loss_gradients, token_roles
from icil_paper.policies.transformer import Transformer, TransformerConfig
from icil_paper.registry import UnknownNameError
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.tokenizers import TOKENIZERS
from icil_paper.tokenizers.configs import default_config

torch.set_num_threads(1)
SPEC = {"proprio": 9, "object": 6}


def policy_config(name, **changes):
    """The smoke preset's config of policy `name` (ICRT's query: 6 steps), with changes."""
    base = get_preset("smoke").policies.get(name)
    if name == "icrt":
        changes = {"query_len": 6, **changes}
    return dataclasses.replace(base, **changes)


def tokenizer_config(name):
    """Tokenizer `name` at test size (D = 16, small codebooks and vocabularies)."""
    if name is None:
        return None
    sizes = {"vq": {"codebook_size": 32}, "lipvq": {"codebook_size": 32},
             "bin": {"n_bins": 32}, "fast": {"vocab_size": 300, "chunk": 4}}.get(name, {})
    return default_config(name, latent_dim=16, **sizes)


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=2, per_task=3, steps=(12, 20), seed=0)


def build(name, tokenizer=None, demos=None, spec=SPEC, **config):
    torch.manual_seed(0)
    policy = make_policy(policy_config(name, **config), spec, 7, tokenizer_config(tokenizer))
    if demos is not None:
        policy.prepare(demos)
    return policy


def single_batch(policy, prompt, query_obs, query_actions):
    """A batch of one (prompt demo, query prefix), all steps real."""
    T = len(query_actions)
    return {
        "prompt_obs": {k: torch.from_numpy(v)[None] for k, v in prompt.obs.items()},
        "prompt_actions": torch.from_numpy(prompt.actions)[None],
        "prompt_valid": torch.ones(1, len(prompt.actions), dtype=torch.bool),
        "query_obs": {k: torch.from_numpy(np.asarray(v[:T]))[None] for k, v in query_obs.items()},
        "query_actions": torch.from_numpy(np.asarray(query_actions, np.float32))[None],
        "query_valid": torch.ones(1, T, dtype=torch.bool),
        "instruction": [prompt.instruction],
    }


# --------------------------------------------------------------------------- transformer
def test_transformer_is_causal():
    torch.manual_seed(0)
    model = Transformer(TransformerConfig(d_model=32, n_layer=2, n_head=4)).eval()
    x = torch.randn(2, 12, 32)
    y = model(x)
    for j in (0, 5, 11):
        x2 = x.clone()
        x2[:, j] += torch.randn(2, 32)
        y2 = model(x2)
        assert torch.equal(y2[:, :j], y[:, :j]), f"changing token {j} changed an earlier output"
        assert not torch.allclose(y2[:, j:], y[:, j:])


def test_kv_cache_equals_full_recomputation():
    torch.manual_seed(0)
    model = Transformer(TransformerConfig(d_model=32, n_layer=3, n_head=4)).eval()
    x = torch.randn(1, 20, 32)
    full = model(x)
    cache = model.new_cache()
    parts = [model(x[:, :9], cache=cache)]  # prefill
    for t in range(9, 20):  # then one or two tokens at a time
        parts.append(model(x[:, t:t + 1], cache=cache))
    torch.testing.assert_close(torch.cat(parts, 1), full, atol=1e-5, rtol=0)


def test_padding_is_invisible():
    """Padding inside a batch changes neither the outputs nor the positions of real tokens."""
    torch.manual_seed(0)
    model = Transformer(TransformerConfig(d_model=16, n_layer=2, n_head=2)).eval()
    a = torch.randn(1, 5, 16)
    b = torch.randn(1, 3, 16)
    # b is padded in the middle (as a short prompt is) and at the end
    x = torch.zeros(2, 8, 16)
    x[0, :5] = a[0]
    x[1, :2], x[1, 4] = b[0, :2], b[0, 2]
    x[1, 2:4] = 99.0
    valid = torch.tensor([[1, 1, 1, 1, 1, 0, 0, 0], [1, 1, 0, 0, 1, 0, 0, 0]], dtype=torch.bool)
    y = model(x, valid)
    torch.testing.assert_close(y[0, :5], model(a)[0], atol=1e-5, rtol=0)
    torch.testing.assert_close(y[1, [0, 1, 4]], model(b)[0], atol=1e-5, rtol=0)


# --------------------------------------------------------------------------- ICRT
def assert_cached_steps_equal_recomputation(policy, demos, steps):
    """Step the policy through demos[1] with demos[0] as prompt (KV cache), then compare with
    one full forward pass over the same prompt, observations and chosen actions."""
    prompt, query = demos[0], demos[1]
    policy.reset(prompt)
    actions = [policy.select_action({k: v[t] for k, v in query.obs.items()})
               for t in range(steps)]
    with torch.no_grad():
        pred, _ = policy.predict(single_batch(policy, prompt, query.obs, actions))
    np.testing.assert_allclose(pred[0, :, 0].numpy(), np.stack(actions), atol=1e-5, rtol=0)

@pytest.mark.parametrize("tokenizer", ["mlp", "lipvq", "bin", "fast", "fsq", "rvq", "bspline"])
def test_icrt_kv_cache_decoding_equals_recomputation(demos, tokenizer):
    assert_cached_steps_equal_recomputation(build("icrt", tokenizer, demos).eval(), demos, 10)


def test_icrt_is_causal_over_the_query(demos):
    policy = build("icrt", "mlp", demos).eval()
    batch = single_batch(policy, demos[0], demos[1].obs, demos[1].actions[:8])
    with torch.no_grad():
        base, _ = policy.predict(batch)
        j = 4
        changed = {**batch, "query_obs": {k: v.clone() for k, v in batch["query_obs"].items()}}
        changed["query_obs"]["proprio"][0, j] += 1.0
        after_obs, _ = policy.predict(changed)
        changed = {**batch, "query_actions": batch["query_actions"].clone()}
        changed["query_actions"][0, j] += 0.5
        after_act, _ = policy.predict(changed)
    assert torch.equal(after_obs[0, :j], base[0, :j])
    assert not torch.allclose(after_obs[0, j], base[0, j])
    # the head at step j reads o_j, which precedes a_j: a_j may only affect steps after j
    assert torch.equal(after_act[0, :j + 1], base[0, :j + 1])
    assert not torch.allclose(after_act[0, j + 1], base[0, j + 1])


def test_icrt_uses_the_prompt(demos):
    policy = build("icrt", "mlp", demos).eval()
    other_task = [d for d in demos if d.task != demos[1].task][0]
    with torch.no_grad():
        a, _ = policy.predict(single_batch(policy, demos[0], demos[1].obs, demos[1].actions[:4]))
        b, _ = policy.predict(single_batch(policy, other_task, demos[1].obs, demos[1].actions[:4]))
    assert not torch.allclose(a, b)


def test_prompt_positions_get_no_loss(demos):
    policy = build("icrt", "mlp", demos)
    data = DemoSet(demos)
    batch = prompt_query_batch(data, 3, 6, policy.chunk_size, 1, np.random.default_rng(0))
    captured = {}

    def keep_output(_module, _inputs, output):
        output.retain_grad()
        captured["h"] = output

    handle = policy.transformer.register_forward_hook(keep_output)
    loss, _ = policy(batch)
    loss.backward()
    handle.remove()
    grad = captured["h"].grad  # (B, L, D)
    M = batch["prompt_valid"].shape[1]
    assert torch.count_nonzero(grad[:, :2 * M]) == 0, "a prompt position received loss gradient"
    query_obs_grad = grad[:, 2 * M::2].abs().sum(-1)  # (B, N)
    assert (query_obs_grad[batch["query_valid"]] > 0).all()
    # query action tokens and query padding get none either
    assert torch.count_nonzero(grad[:, 2 * M + 1::2]) == 0
    assert torch.count_nonzero(query_obs_grad[~batch["query_valid"]]) == 0


def test_token_roles_mark_exactly_where_the_loss_reaches(demos):
    policy = build("icrt", "vq", demos)
    batch = prompt_query_batch(DemoSet(demos), 3, 6, policy.chunk_size, 1, np.random.default_rng(1))
    roles = token_roles(policy, batch)
    grad = token_loss_gradients(policy, batch)
    assert torch.equal(grad > 0, roles["supervised"])
    assert not (roles["supervised"] & (roles["segment"] == 0)).any()
    assert torch.equal(roles["valid"].sum(1), 2 * (batch["prompt_valid"].sum(1) + batch["query_valid"].sum(1)))


def test_padded_batch_matches_single_examples(demos):
    policy = build("icrt", "mlp", demos).eval()
    data = DemoSet(demos)
    batch = prompt_query_batch(data, 4, 6, policy.chunk_size, 1, np.random.default_rng(3))
    assert not batch["prompt_valid"].all(), "want prompts of different lengths"
    with torch.no_grad():
        pred, _ = policy.predict(batch)
        for b in range(4):
            pv, qv = batch["prompt_valid"][b], batch["query_valid"][b]
            one = {
                "prompt_obs": {k: v[b:b + 1, pv] for k, v in batch["prompt_obs"].items()},
                "prompt_actions": batch["prompt_actions"][b:b + 1, pv],
                "prompt_valid": pv[pv][None],
                "query_obs": {k: v[b:b + 1, qv] for k, v in batch["query_obs"].items()},
                "query_actions": batch["query_actions"][b:b + 1, qv],
                "query_valid": qv[qv][None], "instruction": [batch["instruction"][b]],
            }
            single, _ = policy.predict(one)
            torch.testing.assert_close(pred[b, qv], single[0], atol=1e-5, rtol=0)


def test_query_without_actions_follows_eq1(demos):
    policy = build("icrt", "mlp", demos, query_actions=False).eval()
    assert_cached_steps_equal_recomputation(policy, demos, 5)


def test_kv_cache_evicts_old_query_steps_but_keeps_the_prompt(demos):
    prompt = demos[0]
    max_len = 2 * len(prompt.actions) + 8
    policy = build("icrt", "mlp", demos, max_seq_len=max_len).eval()
    policy.reset(prompt)
    obs = {k: v[0] for k, v in demos[1].obs.items()}
    for _ in range(12):
        assert np.isfinite(policy.select_action(obs)).all()
        assert len(policy._cache) <= max_len
    assert len(policy._cache) == max_len - 1 or len(policy._cache) == max_len


# --------------------------------------------------------------------------- errors
def test_bad_prompts_raise_clear_errors(demos):
    policy = build("icrt", "mlp", demos).eval()
    with pytest.raises(ValueError, match="empty prompt"):
        policy.reset([])
    empty = dataclasses.replace(demos[0], actions=np.zeros((0, 7), np.float32),
                                obs={k: v[:0] for k, v in demos[0].obs.items()})
    with pytest.raises(ValueError, match="empty prompt"):
        policy.reset(empty)
    wrong = dataclasses.replace(demos[0], actions=demos[0].actions[:, :6])
    with pytest.raises(ValueError, match="wrong action dimension"):
        policy.reset(wrong)
    with pytest.raises(ValueError, match="needs a prompt"):
        policy.reset(None)
    missing = dataclasses.replace(demos[0], obs={"proprio": demos[0].obs["proprio"]})
    with pytest.raises(ValueError, match="object"):
        policy.reset(missing)
    fresh = build("icrt", "mlp", demos).eval()
    with pytest.raises(RuntimeError, match="reset"):
        fresh.select_action({k: v[0] for k, v in demos[0].obs.items()})


def test_bad_names_and_combinations_raise():
    with pytest.raises(UnknownNameError, match="icrt"):
        make_policy("icrtt", 15, 7)
    with pytest.raises(UnknownNameError, match="lipvq"):
        make_policy(policy_config("icrt"), 15, 7, "lipvqq")
    with pytest.raises(ValueError, match="does not take the 'mlp' action tokenizer"):
        make_policy(policy_config("bc_transformer"), 15, 7, "mlp")
    with pytest.raises(ValueError, match="image observations"):
        make_policy(policy_config("mcr"), 15, 7)
    with pytest.raises(ValueError, match="wrong action dimension"):
        policy = build("act", "mlp")
        policy.tokenizer(torch.zeros(1, 2, 6))


# --------------------------------------------------------------------------- every policy
COMBOS = ([("icrt", t) for t in TOKENIZERS] + [("act", None)] + [("act", t) for t in TOKENIZERS]
          + [("bc_transformer", None), ("mcr", None)])


@pytest.mark.parametrize("name,tokenizer", COMBOS, ids=[f"{p}+{t}" for p, t in COMBOS])
def test_every_combination_trains_and_acts(name, tokenizer):
    image = (1, 16, 16) if name == "mcr" else None
    demos = synthetic_demos(2, 2, steps=(10, 14), image=image, seed=1)
    spec = {k: v.shape[1:] for k, v in demos[0].obs.items()}
    policy = build(name, tokenizer, spec=spec, **({"pretrain_steps": 2} if name == "mcr" else {}))
    data = policy.prepare(demos)
    rng = np.random.default_rng(0)
    params = [p for p in policy.parameters() if p.requires_grad]
    before = [p.detach().clone() for p in params]
    opt = torch.optim.AdamW(params, lr=1e-3)
    for _ in range(2):
        loss, info = policy(policy.sample_batch(data, 2, rng))
        assert torch.isfinite(loss) and all(np.isfinite(v) for v in info.values())
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert any(not torch.equal(a, b) for a, b in zip(before, params, strict=True))
    policy.eval()
    policy.reset(prompt=demos[0], instruction=demos[0].instruction)
    for t in range(3):
        action = policy.select_action({k: v[t] for k, v in demos[1].obs.items()})
        assert action.shape == (7,) and action.dtype == np.float32 and np.isfinite(action).all()


def test_registry_lists_every_policy():
    assert set(POLICIES) == {"icrt", "bc_transformer", "act", "mcr"}


# --------------------------------------------------------------------------- parts
def test_resnet18_follows_torchvision_layout():
    net = ResNet18(in_channels=3, width=64, norm="batch", num_classes=1000)
    assert sum(p.numel() for p in net.parameters()) == 11_689_512  # torchvision's resnet18
    names = {n for n, _ in net.named_parameters()}
    assert {"conv1.weight", "bn1.weight", "layer1.0.conv1.weight", "layer2.0.downsample.0.weight",
            "layer4.1.bn2.bias", "fc.weight"} <= names
    small = ResNet18(in_channels=4, width=8).eval()
    assert small(torch.zeros(2, 4, 32, 32)).shape == (2, 64)


def test_hashed_text_embedding_is_stable():
    emb = HashedTextEmbedding(8, n_buckets=64)
    a, b = emb(["Open the drawer", "open the DRAWER!"]), emb(["close the door"] * 2)
    torch.testing.assert_close(a[0], a[1])
    assert not torch.allclose(a[0], b[0])


def test_obs_spec_forms():
    assert as_obs_spec(15).lowdim_dim == 15
    spec = as_obs_spec({"proprio": (9,), "object": 6, "rgb": (2, 16, 16, 3), "depth": (2, 16, 16)})
    assert spec.lowdim_dim == 15 and spec.image == (2, 16, 16) and spec.depth
    with pytest.raises(ValueError, match="rgb"):
        as_obs_spec({"proprio": 9, "rgb": (16, 16, 3)})


def test_temporal_ensemble_weights_older_predictions_more():
    ens = TemporalEnsemble(chunk_size=3, m=0.5)
    first = ens(np.array([[0.0], [1.0], [2.0]]))
    second = ens(np.array([[10.0], [11.0], [12.0]]))
    assert first[0] == 0.0
    w = np.exp(-0.5 * np.arange(2))
    assert second[0] == pytest.approx((w[0] * 1.0 + w[1] * 10.0) / w.sum())


@pytest.mark.parametrize("name,tokenizer", [("icrt", "mlp"), ("act", None),
                                            ("bc_transformer", None)])
def test_nan_observations_are_refused_and_leave_no_trace(name, tokenizer, demos):
    policy = build(name, tokenizer, demos).eval()
    policy.reset(prompt=demos[0], instruction=demos[0].instruction)
    good = {k: v[0] for k, v in demos[1].obs.items()}
    first = policy.select_action(good)
    bad = {**good, "object": np.full_like(good["object"], np.nan)}
    with pytest.raises(ValueError, match="'object' contains NaN"):
        policy.select_action(bad)
    assert np.isfinite(policy.select_action(good)).all() and np.isfinite(first).all()
    nan_prompt = dataclasses.replace(demos[0], obs={**demos[0].obs,
                                                    "proprio": demos[0].obs["proprio"] * np.nan})
    if policy.uses_prompt:
        with pytest.raises(ValueError, match="contains NaN"):
            policy.reset(prompt=nan_prompt)


def test_training_benchmark_times_a_preset_size():
    """The policies benchmark's training row: the preset's batch and model, a positive rate,
    fp32 and no peak memory on the CPU."""
    from tools.bench.policies import training_speed

    row = training_speed("reference", torch.device("cpu"), steps=2)
    assert row["batch_size"] == 8 and row["d_model"] == 64 and row["steps"] == 2
    assert row["steps_per_s"] > 0 and row["precision"] == "fp32"
    assert row["peak_memory_mib"] is None
