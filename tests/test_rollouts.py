"""The rollout engine: a batched KV cache equals one cache per episode, every policy's batched
acting equals acting one episode at a time, and per-episode outcomes do not depend on how
episodes are batched (synthetic suite; a kitchen task with the simulator)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.eval import evaluate_many, evaluate_policy
from icil_paper.eval.rollouts import (
    Episode,
    default_batch_size,
    group_episodes,
    rollout_batch,
)
from icil_paper.policies import make_policy
from icil_paper.policies.base import Policy, validate_prompt
from icil_paper.policies.configs import ICRTConfig
from icil_paper.policies.transformer import Transformer, TransformerConfig
from icil_paper.runspec import EvalSpec
from icil_paper.sim.synthetic import (
    SyntheticReachEnv,
    make_synthetic_env,
    synthetic_demos,
)
from icil_paper.tokenizers.configs import default_config
from oracle_policy import OraclePolicy

SPEC = {"proprio": 9, "object": 6}


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=3, per_task=2, steps=(8, 24), seed=0)


def build(name, tokenizer=None, demos=None, spec=SPEC, **config):
    """A smoke-size policy (untrained), prepared on `demos`."""
    torch.manual_seed(0)
    sizes = {"vq": {"codebook_size": 32}, "lipvq": {"codebook_size": 32},
             "fast": {"vocab_size": 300, "chunk": 4}}.get(tokenizer, {})
    tok = default_config(tokenizer, latent_dim=16, **sizes) if tokenizer else None
    cfg = dataclasses.replace(get_preset("smoke").policies.get(name), **config)
    policy = make_policy(cfg, spec, 7, tok)
    if demos is not None:
        policy.prepare(demos)
    return policy.eval()


def obs_at(demo, t):
    return {k: v[t % len(demo.actions)] for k, v in demo.obs.items()}


def act_one_by_one(policy, prompts, queries, steps):
    """Each episode alone: reset(prompt), then select_action for its steps."""
    out = []
    for prompt, query, n in zip(prompts, queries, steps, strict=True):
        policy.reset(prompt)
        out.append(np.stack([policy.select_action(obs_at(query, t)) for t in range(n)]))
    return out


def act_batched(policy, prompts, queries, steps):
    """All episodes in lockstep; an episode leaves the batch after its steps."""
    policy.reset_batch(prompts)
    out = [[] for _ in prompts]
    for t in range(max(steps)):
        rows = [i for i, n in enumerate(steps) if t < n]
        actions = policy.select_actions([obs_at(queries[i], t) for i in rows], rows=rows)
        assert actions.shape == (len(rows), 7)
        for i, a in zip(rows, actions, strict=True):
            out[i].append(a)
    return [np.stack(o) for o in out]


# --------------------------------------------------------------------------- the batched cache
def test_batched_kv_cache_equals_one_cache_per_sequence():
    """Sequences of different lengths, padded at their end, prefilled in one batch, then
    extended token by token while one of them drops out: each row equals its own cache."""
    torch.manual_seed(0)
    model = Transformer(TransformerConfig(d_model=16, n_layer=2, n_head=2)).eval()
    lengths, extra = [5, 9, 2], 70  # more steps than the cache's first buffer holds
    seqs = [torch.randn(1, n + extra, 16) for n in lengths]
    alone = []
    for x, n in zip(seqs, lengths, strict=True):
        cache = model.new_cache()
        parts = [model(x[:, :n], cache=cache)[:, -1:]]
        parts += [model(x[:, t:t + 1], cache=cache) for t in range(n, n + extra)]
        alone.append(torch.cat(parts, 1))
    M = max(lengths)
    x = torch.zeros(3, M, 16)
    valid = torch.zeros(3, M, dtype=torch.bool)
    for b, n in enumerate(lengths):
        x[b, :n], valid[b, :n] = seqs[b][0, :n], True
    cache = model.new_cache()
    y = model(x, valid, cache=cache)
    got = [[y[b, n - 1]] for b, n in enumerate(lengths)]
    rows = [0, 1, 2]
    for t in range(extra):
        if t == 20:  # sequence 1 ends: its row leaves the cache
            rows = [0, 2]
            cache.select_rows([0, 2])
            assert len(cache) == M + 20 - (M - max(lengths[0], lengths[2]))
        step = torch.cat([seqs[b][:, lengths[b] + t] for b in rows])[:, None]
        out = model(step, cache=cache)
        for j, b in enumerate(rows):
            got[b].append(out[j, 0])
    for b in (0, 2):
        torch.testing.assert_close(torch.stack(got[b]), alone[b][0], atol=1e-5, rtol=0)
    torch.testing.assert_close(torch.stack(got[1]), alone[1][0, :21], atol=1e-5, rtol=0)


@pytest.mark.parametrize("tokenizer", ["mlp", "lipvq", "fast"])
@pytest.mark.parametrize("max_seq_len", [512, 64], ids=["no-eviction", "eviction"])
def test_icrt_batched_acting_equals_one_episode_at_a_time(demos, tokenizer, max_seq_len):
    policy = build("icrt", tokenizer, demos, max_seq_len=max_seq_len)
    prompts = [[demos[0]], [demos[2], demos[4]], [demos[5]]]
    assert len({sum(len(d.actions) for d in p) for p in prompts}) == 3  # different lengths
    queries, steps = [demos[1], demos[3], demos[4]], [30, 9, 22]
    alone = act_one_by_one(policy, prompts, queries, steps)
    together = act_batched(policy, prompts, queries, steps)
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_allclose(b, a, atol=1e-5, rtol=0)
        assert np.abs(a).max() <= 1.0  # clipped: what the env executes
    if max_seq_len == 64:  # the longest prompt's row evicted query steps, the cache stayed small
        assert policy._cache.valid.sum(1).max() <= max_seq_len


@pytest.mark.parametrize("name,tokenizer", [("act", None), ("act", "lipvq"),
                                            ("bc_transformer", None)])
def test_baselines_batched_acting_equals_one_episode_at_a_time(demos, name, tokenizer):
    policy = build(name, tokenizer, demos)
    queries, steps = [demos[1], demos[3], demos[4]], [12, 5, 9]
    alone = act_one_by_one(policy, [None] * 3, queries, steps)
    together = act_batched(policy, [None] * 3, queries, steps)
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_allclose(b, a, atol=1e-5, rtol=0)


def test_mcr_batched_acting_equals_one_episode_at_a_time():
    image_demos = synthetic_demos(n_tasks=2, per_task=2, steps=10, image=(1, 16, 16), seed=1)
    spec = {"proprio": 9, "object": 6, "rgb": (1, 16, 16, 3)}
    policy = build("mcr", None, image_demos, spec=spec)
    queries, steps = image_demos, [6, 3, 6, 1]
    alone = act_one_by_one(policy, [None] * 4, queries, steps)
    together = act_batched(policy, [None] * 4, queries, steps)
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_allclose(b, a, atol=1e-5, rtol=0)



def oracle():
    return OraclePolicy(ICRTConfig(), SPEC, 7)


def test_the_default_batched_acting_keeps_one_copy_per_episode(demos):
    policy = oracle()
    prompts = [[demos[0]], [demos[2]], [demos[4]]]
    queries, steps = [demos[1], demos[3], demos[5]], [6, 2, 4]
    alone = act_one_by_one(policy, prompts, queries, steps)
    together = act_batched(policy, prompts, queries, steps)
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_array_equal(b, a)


def test_a_finished_episode_cannot_come_back(demos):
    policy = build("icrt", "mlp", demos)
    policy.reset_batch([[demos[0]], [demos[1]]])
    policy.select_actions([obs_at(demos[0], 0)], rows=[1])
    with pytest.raises(ValueError, match="cannot come back"):
        policy.select_actions([obs_at(demos[0], 1), obs_at(demos[1], 1)], rows=[0, 1])
    with pytest.raises(ValueError, match="2 observations for 1 rows"):
        policy.select_actions([obs_at(demos[0], 1), obs_at(demos[1], 1)], rows=[1])
    with pytest.raises(ValueError, match="instructions"):
        policy.reset_batch([[demos[0]], [demos[1]]], ["only one"])


# --------------------------------------------------------------------------- groups
def episodes_of(specs, per_spec):
    return [Episode(spec=s, task=f"synthetic/task{s % 10}", index=i, seed=100 * s + i)
            for s in range(specs) for i in range(per_spec)]


@pytest.mark.parametrize("specs,per_spec", [(11, 4), (11, 5), (1, 5), (3, 2), (20, 3)])
def test_default_groups_cover_every_episode_once(specs, per_spec):
    episodes = episodes_of(specs, per_spec)
    b = default_batch_size(episodes)
    groups = group_episodes(episodes, b)
    flat = [e for g in groups for e in g]
    assert sorted(flat, key=lambda e: (e.spec, e.index)) == episodes
    assert all(1 <= len(g) <= b for g in groups)
    assert max(map(len, groups)) - min(map(len, groups)) <= 1  # nearly equal sizes
    assert b == min(specs, 16) or specs > 16  # one episode per spec, as wide as allowed
    assert all(len({e.spec for e in g}) == len(g) for g in groups)  # one env per task
    assert group_episodes(list(reversed(episodes)), b) == groups  # the order given is moot


# --------------------------------------------------------------------------- many episodes
class ProbeEnv(SyntheticReachEnv):
    """Synthetic reach whose outcome hangs on the policy's exact actions: success once the
    running sum of the first action entry passes a threshold drawn at reset, so episodes
    end after different numbers of steps (or run to the limit)."""

    def reset(self, seed=None, options=None):
        obs, info = super().reset(seed=seed, options=options)
        self.total, self.threshold = 0.0, float(self.np_random.uniform(0.5, 12.0))
        return obs, info

    def step(self, action):
        obs, _, _, truncated, _ = super().step(np.clip(10 * np.asarray(action), -1, 1))
        self.total += float(action[0])
        success = abs(self.total) > self.threshold
        return obs, float(action[0]), success, truncated and not success, {"success": success}


def probe_env(name, obs="state", seed=0, **options):
    return ProbeEnv(name, obs=obs, seed=seed, **options)


def outcomes(results):
    return [[(e["episode"], e["seed"], e["success"], e["steps"]) for e in r.per_episode]
            for r in results]


def without_times(results):
    return [[{k: v for k, v in e.items() if k != "wall_time_s"} for e in r.per_episode]
            for r in results]


PROBE_SPECS = [EvalSpec(task=f"synthetic/task{k}", episodes=5, seed=k, max_steps=15)
               for k in range(3)]


def test_outcomes_do_not_depend_on_batch_size(demos):
    # without the instruction: this seed's untrained policy then acts varied enough for the
    # probe (some episodes succeed early, some run to the limit)
    policy = build("icrt", "lipvq", demos, language=False)
    prompts = {s.task: [d for d in demos if d.task == s.task] for s in PROBE_SPECS}

    def run(**kw):
        return evaluate_many(policy, PROBE_SPECS, prompts, env_factory=probe_env,
                             progress=False, **kw)

    one_by_one = run(batch_size=1)
    steps = [e["steps"] for r in one_by_one for e in r.per_episode]
    assert len(set(steps)) > 3 and 15 in steps and min(steps) < 15  # varied, some fail
    five = run(batch_size=5)
    assert outcomes(five) == outcomes(one_by_one)
    returns = [[e["return"] for e in r.per_episode] for r in five]
    np.testing.assert_allclose(returns, [[e["return"] for e in r.per_episode]
                                         for r in one_by_one], atol=1e-4)
    assert without_times(run(batch_size=5)) == without_times(five)  # bit for bit
    assert outcomes(run()) == outcomes(one_by_one)  # default: batches of 3, one per task


def test_evaluate_many_equals_evaluate_policy_per_spec(demos):
    policy = oracle()
    specs = [EvalSpec(task="synthetic/task1", episodes=3, seed=2, max_steps=40),
             EvalSpec(task="synthetic/task2", episodes=2, seed=5, max_steps=40)]
    pools = [[d for d in demos if d.task == s.task] for s in specs]
    many = evaluate_many(policy, specs, pools, env_factory=make_synthetic_env, progress=False,
                         batch_size=5)
    alone = [evaluate_policy(policy, s, p, env_factory=make_synthetic_env, progress=False)
             for s, p in zip(specs, pools, strict=True)]
    assert without_times(many) == without_times(alone)
    assert [r.success_rate for r in many] == [1.0, 1.0]
    with pytest.raises(ValueError, match="one per spec"):
        evaluate_many(policy, specs, [pools[0]], env_factory=make_synthetic_env)


def test_an_env_reset_does_not_depend_on_its_history():
    """What lets the engine reuse one env for many episodes."""
    fresh = make_synthetic_env("synthetic/task0")
    used = make_synthetic_env("synthetic/task0", seed=9)
    used.reset(seed=3)
    for _ in range(5):
        used.step(np.ones(7, np.float32))
    a, b = fresh.reset(seed=42)[0], used.reset(seed=42)[0]
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_rollout_batch_checks_its_arguments():
    env = make_synthetic_env("synthetic/task0")
    with pytest.raises(ValueError, match="seeds"):
        rollout_batch(oracle(), [env], [1, 2])


# --------------------------------------------------------------------------- with the simulator
KITCHEN_TASK = "kitchen/open_drawer"


class ReplayPolicy(Policy):
    """Replays its prompt demonstration's actions open loop (zeros after its end): no
    randomness and no float arithmetic, so its outcomes are the scenes' alone."""

    name = "replay"
    uses_prompt = True

    def reset(self, prompt=None, instruction=None):
        self.actions = validate_prompt(prompt, self.obs_spec, self.action_dim)[0].actions
        self.t = 0

    def select_action(self, obs):
        a = self.actions[self.t] if self.t < len(self.actions) else np.zeros(7, np.float32)
        self.t += 1
        return np.asarray(a, np.float32)


@pytest.mark.sim
def test_kitchen_outcomes_do_not_depend_on_batch_size(tmp_path, monkeypatch):
    from icil_paper import sim

    reason = sim.suite_unavailable("kitchen")
    if reason:
        pytest.skip(f"kitchen suite unavailable: {reason}")
    from icil_paper.data import ensure_demos, load_demos

    monkeypatch.setenv("ICIL_DATA", str(tmp_path))
    prompts = load_demos(ensure_demos("smoke", KITCHEN_TASK, "generated", progress=False))
    replay = ReplayPolicy(ICRTConfig(), {"proprio": 9, "object": 18}, 7)
    icrt = build("icrt", "lipvq", prompts, spec={"proprio": 9, "object": 18})
    ev = EvalSpec(task=KITCHEN_TASK, episodes=3, max_steps=60)
    runs = {"replay": (replay, [{"batch_size": 3}]),
            "icrt": (icrt, [{"batch_size": 3}, {"batch_size": 2}])}
    for policy, variants in runs.values():
        base = evaluate_policy(policy, ev, prompts, progress=False)
        for kw in variants:
            other = evaluate_policy(policy, ev, prompts, progress=False, **kw)
            assert outcomes([other]) == outcomes([base]), kw
