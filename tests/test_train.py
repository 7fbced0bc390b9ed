"""The training loop: overfitting, bit-exact resume, checkpoints, schedule, EMA, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.policies.synthetic import synthetic_demos
from icil_paper.train import (
    CHECKPOINT,
    METRICS_FILE,
    POLICY_FILE,
    cosine_schedule,
    load_policy,
    policy_digest,
    train_policy,
)

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=2, per_task=3, steps=(10, 14), seed=0)


def smoke(**train):
    return get_preset("smoke").replace(train=train) if train else get_preset("smoke")


def states_equal(a, b) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(
        torch.equal(sa[k], sb[k]) for k in sa if isinstance(sa[k], torch.Tensor))


def test_tiny_icrt_overfits_one_demonstration():
    demo = synthetic_demos(n_tasks=1, per_task=1, steps=12, seed=3)
    preset = get_preset("smoke").replace(
        train={"steps": 100, "batch_size": 4, "lr": 3e-3, "warmup_steps": 10, "log_every": 1,
               "query_len": 12, "weight_decay": 0.0},
        policy={"d_model": 32, "n_layer": 1, "chunk_size": 1})
    result = train_policy(preset, "icrt", "mlp", demos=demo, run_dir=None, progress=False)
    first = np.mean([h["action_l1"] for h in result.history[:3]])
    last = np.mean([h["action_l1"] for h in result.history[-3:]])
    assert last < first / 10, f"action loss fell only from {first:.4f} to {last:.4f}"


@pytest.mark.parametrize("policy,tokenizer,ema", [("icrt", "lipvq", 0.9), ("act", None, None),
                                                  ("bc_transformer", None, None),
                                                  ("icrt", "fast", None)])
def test_resume_equals_uninterrupted_training(tmp_path, demos, policy, tokenizer, ema):
    preset = get_preset("smoke").replace(train={"steps": 7, "ckpt_every": 3, "ema_decay": ema},
                                         policy={"dropout": 0.1})  # dropout draws from torch's RNG
    kw = dict(demos=demos, progress=False)
    straight = train_policy(preset, policy, tokenizer, run_dir=tmp_path / "a", **kw)
    killed = train_policy(preset, policy, tokenizer, run_dir=tmp_path / "b", stop_after=4, **kw)
    assert killed.metrics["steps"] == 4 and not (tmp_path / "b" / POLICY_FILE).exists()
    ckpt = torch.load(tmp_path / "b" / CHECKPOINT, weights_only=False)
    assert ckpt["step"] == 4
    # lines logged after the checkpoint would be redone; simulate a kill just before step 6
    with open(tmp_path / "b" / METRICS_FILE, "a") as f:
        f.write(json.dumps({"step": 5, "loss": -1.0}) + "\n")
    resumed = train_policy(preset, policy, tokenizer, run_dir=tmp_path / "b", **kw)
    assert resumed.metrics["steps"] == 7
    assert states_equal(straight.policy, resumed.policy)
    def logged(run):
        lines = (tmp_path / run / METRICS_FILE).read_text().splitlines()
        return [{k: v for k, v in json.loads(x).items() if k != "elapsed_s"} for x in lines]

    assert logged("a") == logged("b")


def test_checkpoint_and_policy_files(tmp_path, demos):
    preset = smoke(steps=4, ckpt_every=2)
    result = train_policy(preset, "icrt", "bin", demos=demos, run_dir=tmp_path, progress=False)
    ckpt = torch.load(tmp_path / CHECKPOINT, weights_only=False)
    assert {"step", "model", "optimizer", "scheduler", "ema", "rng", "spec", "config"} <= set(ckpt)
    assert ckpt["step"] == 4
    assert not list(tmp_path.glob(".*.tmp")), "a temporary file was left behind"
    lines = [json.loads(x) for x in (tmp_path / METRICS_FILE).read_text().splitlines()]
    assert [x["step"] for x in lines] == [1, 2, 3, 4]
    assert all(np.isfinite(x["loss"]) and "lr" in x and "grad_norm" in x for x in lines)
    # the bin tokenizer was fitted on the training actions before training
    actions = np.concatenate([d.actions for d in demos])
    np.testing.assert_allclose(result.policy.tokenizer.low.numpy(), actions.min(0), atol=1e-3)
    np.testing.assert_allclose(result.policy.tokenizer.high.numpy(), actions.max(0), atol=1e-3)
    loaded = load_policy(tmp_path)
    assert policy_digest(loaded) == policy_digest(result.policy)
    loaded.reset(demos[0])
    result.policy.reset(demos[0])
    obs = {k: v[0] for k, v in demos[1].obs.items()}
    np.testing.assert_array_equal(loaded.select_action(obs), result.policy.select_action(obs))


def test_resume_refuses_a_different_run(tmp_path, demos):
    train_policy(smoke(steps=2), "icrt", "mlp", demos=demos, run_dir=tmp_path, progress=False)
    with pytest.raises(ValueError, match="different run"):
        train_policy(smoke(steps=2), "icrt", "vq", demos=demos, run_dir=tmp_path, progress=False)
    # a finished run resumes to itself without training again
    again = train_policy(smoke(steps=2), "icrt", "mlp", demos=demos, run_dir=tmp_path,
                         progress=False)
    assert again.history == [] and again.metrics["steps"] == 2


def test_warmup_then_cosine_to_zero():
    f = cosine_schedule(warmup=4, total=20)
    assert [f(s) for s in range(4)] == [0.25, 0.5, 0.75, 1.0]
    values = [f(s) for s in range(4, 21)]
    assert values[0] == pytest.approx(1.0) and values[-1] == pytest.approx(0.0, abs=1e-12)
    assert all(a >= b for a, b in zip(values, values[1:], strict=False))


def test_ema_weights_are_the_returned_policy(demos):
    plain = train_policy(smoke(steps=5), "bc_transformer", demos=demos, run_dir=None, progress=False)
    averaged = train_policy(smoke(steps=5, ema_decay=0.5), "bc_transformer", demos=demos,
                            run_dir=None, progress=False)
    assert not states_equal(plain.policy, averaged.policy)


def test_train_cli_writes_run_and_record(tmp_path, demos, monkeypatch):
    import icil_paper.train as train_module
    from icil_paper.results import ResultsStore

    monkeypatch.setattr(train_module, "load_training_demos", lambda *a, **k: demos)
    code = train_module.main(["--preset", "smoke", "--policy", "act", "--tokenizer", "lipvq",
                              "--tasks", "synthetic/task0", "--run-dir", str(tmp_path / "run"),
                              "--quiet"])
    assert code == 0
    assert (tmp_path / "run" / POLICY_FILE).exists()
    table = ResultsStore("smoke").table("train")
    assert list(table["name"]) == ["act+lipvq__synthetic__generated"]
    assert table["steps"].iloc[0] == get_preset("smoke").train.steps


def test_default_run_dir_follows_what_training_depends_on(tmp_path, monkeypatch):
    from icil_paper.train import default_run_dir

    monkeypatch.setenv("ICIL_RUNS", str(tmp_path))
    preset = get_preset("smoke")
    run = lambda p: default_run_dir(p, "icrt", "lipvq", ["kitchen/open_drawer"], "generated")
    base = run(preset)
    assert base.parent == tmp_path / "smoke"
    assert base.name.startswith("icrt+lipvq__kitchen-open_drawer__generated__seed0__")
    assert run(get_preset("smoke")) == base  # stable
    assert run(preset.replace(eval={"episodes_per_task": 7})) == base  # evaluation only
    for changed in (preset.replace(train={"steps": 6}), preset.replace(policy={"d_model": 64}),
                    preset.replace(tokenizer={"codebook_size": 32}), get_preset("smoke", seed=1)):
        assert run(changed) != base
