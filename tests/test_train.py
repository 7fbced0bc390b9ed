"""The training loop: overfitting, bit-exact resume, safe checkpoints and policy files,
recovery from damaged run files, schedule, EMA, the CLI."""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.runspec import run_spec
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.train import (
    CONFIG_FILE,
    METRICS_FILE,
    POLICY_FILE,
    PolicyFileError,
    RunFolderError,
    load_policy,
    policy_digest,
    read_metrics,
    run_dir_for,
    rundir,
    train_policy,
)
from icil_paper.train.optim import cosine_schedule
from icil_paper.train.rundir import CHECKPOINT, PREVIOUS_CHECKPOINT, DamagedFileWarning

torch.set_num_threads(1)
TASKS = ["synthetic/task0", "synthetic/task1"]


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=2, per_task=3, steps=(10, 14), seed=0)


def spec(policy="icrt", tokenizer=None, overrides=(), seed=None):
    preset = get_preset("smoke").with_overrides(list(overrides))
    return run_spec(preset, policy, tokenizer, tasks=TASKS, seed=seed)


def states_equal(a, b) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(
        torch.equal(sa[k], sb[k]) for k in sa if isinstance(sa[k], torch.Tensor))


def test_tiny_icrt_overfits_one_demonstration():
    demo = synthetic_demos(n_tasks=1, per_task=1, steps=12, seed=3)
    s = spec("icrt", "mlp", ["train.steps=100", "train.batch_size=4", "train.lr=3e-3",
                             "train.warmup_steps=10", "train.log_every=1",
                             "train.weight_decay=0", "policies.icrt.query_len=12",
                             "policies.icrt.chunk_size=1"])
    result = train_policy(s, run_dir=None, demos=demo, progress=False)
    first = np.mean([h["action_l1"] for h in result.history[:3]])
    last = np.mean([h["action_l1"] for h in result.history[-3:]])
    assert last < first / 10, f"action loss fell only from {first:.4f} to {last:.4f}"


@pytest.mark.parametrize("policy,tokenizer,ema", [("icrt", "lipvq", 0.9), ("act", None, None),
                                                  ("bc_transformer", None, None),
                                                  ("icrt", "fast", None)])
def test_resume_equals_uninterrupted_training(tmp_path, demos, policy, tokenizer, ema):
    s = spec(policy, tokenizer, ["train.steps=7", "train.ckpt_every=3", f"train.ema_decay={ema}",
                                 f"policies.{policy}.dropout=0.1"])  # dropout draws from torch
    kw = dict(demos=demos, progress=False)
    straight = train_policy(s, run_dir=tmp_path / "a", **kw)
    killed = train_policy(s, run_dir=tmp_path / "b", stop_after=4, **kw)
    assert killed.metrics["steps"] == 4 and not (tmp_path / "b" / POLICY_FILE).exists()
    # lines logged after the checkpoint would be redone; simulate a kill mid-line at step 6
    with open(tmp_path / "b" / METRICS_FILE, "a") as f:
        f.write(json.dumps({"step": 5, "loss": -1.0}) + "\n" + '{"step": 6, "lo')
    resumed = train_policy(s, run_dir=tmp_path / "b", **kw)
    assert resumed.metrics["steps"] == 7
    assert (straight.metrics["resumed_from_step"], resumed.metrics["resumed_from_step"]) == (0, 4)
    assert states_equal(straight.policy, resumed.policy)

    def logged(run):
        return [{k: v for k, v in x.items() if k != "elapsed_s"}
                for x in read_metrics(tmp_path / run / METRICS_FILE)]

    assert logged("a") == logged("b")


def test_rng_states_restore_from_a_checkpoint_mapped_off_the_cpu():
    # Resuming on a GPU loads the checkpoint with map_location="cuda", which moves the RNG
    # states off the CPU; torch's setters take CPU ByteTensors only. A tensor of another
    # dtype stands in for that here (the GPU case runs in the test below).
    rng = np.random.default_rng(0)
    state = dict(rundir.rng_state(rng))
    expected = torch.rand(3)
    state["torch"] = state["torch"].to(torch.int64)
    rundir.set_rng_state(rng, state)
    assert torch.equal(torch.rand(3), expected)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_a_run_killed_on_the_gpu_resumes_there(tmp_path, demos):
    s = spec("icrt", "lipvq", ["train.steps=7", "train.ckpt_every=3"])
    kw = dict(demos=demos, progress=False, device="cuda")
    killed = train_policy(s, run_dir=tmp_path, stop_after=4, **kw)
    assert killed.metrics["steps"] == 4
    resumed = train_policy(s, run_dir=tmp_path, **kw)
    assert (resumed.metrics["steps"], resumed.metrics["resumed_from_step"]) == (7, 4)


def test_checkpoint_and_policy_files_are_safe_to_load(tmp_path, demos):
    s = spec("icrt", "bin", ["train.steps=4", "train.ckpt_every=2"])
    result = train_policy(s, run_dir=tmp_path, demos=demos, progress=False)
    ckpt = torch.load(tmp_path / CHECKPOINT, weights_only=True)  # tensors, numbers, strings
    assert {"step", "key", "model", "optimizer", "scheduler", "ema", "rng"} <= set(ckpt)
    assert ckpt["step"] == 4 and ckpt["key"] == s.key()
    assert (tmp_path / PREVIOUS_CHECKPOINT).exists()
    assert not list(tmp_path.glob(".*.tmp")), "a temporary file was left behind"
    assert oct(os.stat(tmp_path / POLICY_FILE).st_mode & 0o777) != "0o600"
    lines = read_metrics(tmp_path / METRICS_FILE)
    assert [x["step"] for x in lines] == [1, 2, 3, 4]
    assert all(np.isfinite(x["loss"]) and "lr" in x and "grad_norm" in x for x in lines)
    # the bin tokenizer was fitted on the training actions before training
    actions = np.concatenate([d.actions for d in demos])
    np.testing.assert_allclose(result.policy.tokenizer.low.numpy(), actions.min(0), atol=1e-3)
    loaded = load_policy(tmp_path)
    assert policy_digest(loaded) == policy_digest(result.policy)
    assert loaded.meta["key"] == s.key()
    loaded.reset(demos[0])
    result.policy.reset(demos[0])
    obs = {k: v[0] for k, v in demos[1].obs.items()}
    np.testing.assert_array_equal(loaded.select_action(obs), result.policy.select_action(obs))


def test_a_pickled_policy_file_is_refused(tmp_path):
    class Payload:
        def __reduce__(self):
            return (os.system, ("touch " + str(tmp_path / "pwned"),))

    torch.save({"format": "icil_paper.policy/2", "spec": Payload()}, tmp_path / POLICY_FILE)
    with pytest.raises(PolicyFileError, match="reads safely"):
        load_policy(tmp_path)
    assert not (tmp_path / "pwned").exists()
    (tmp_path / POLICY_FILE).write_bytes(b"not a policy")
    with pytest.raises(PolicyFileError):
        load_policy(tmp_path)
    with pytest.raises(FileNotFoundError, match="train it first"):
        load_policy(tmp_path / "elsewhere")


def test_resume_refuses_a_different_run(tmp_path, demos):
    train_policy(spec("icrt", "mlp", ["train.steps=2"]), run_dir=tmp_path, demos=demos,
                 progress=False)
    with pytest.raises(RunFolderError, match="different run.*--no-resume"):
        train_policy(spec("icrt", "vq", ["train.steps=2"]), run_dir=tmp_path, demos=demos,
                     progress=False)
    # a finished run resumes to itself without training again
    again = train_policy(spec("icrt", "mlp", ["train.steps=2"]), run_dir=tmp_path, demos=demos,
                         progress=False)
    assert again.history == [] and again.metrics["steps"] == 2


def test_a_truncated_checkpoint_falls_back_to_the_previous_one(tmp_path, demos):
    s = spec("icrt", "mlp", ["train.steps=6", "train.ckpt_every=2"])
    straight = train_policy(s, run_dir=tmp_path / "a", demos=demos, progress=False)
    train_policy(s, run_dir=tmp_path / "b", demos=demos, progress=False, stop_after=4)
    ckpt = tmp_path / "b" / CHECKPOINT
    ckpt.write_bytes(ckpt.read_bytes()[:100])  # torn by a crash
    with pytest.warns(DamagedFileWarning, match="checkpoint"):
        resumed = train_policy(s, run_dir=tmp_path / "b", demos=demos, progress=False)
    assert states_equal(straight.policy, resumed.policy)  # from step 2, bit for bit
    assert list((tmp_path / "b").glob(f"{CHECKPOINT}.corrupt-*")), "the damaged file is kept"


def test_a_checkpoint_of_another_run_is_refused_without_config(tmp_path, demos):
    train_policy(spec("icrt", "mlp", ["train.steps=3"]), run_dir=tmp_path, demos=demos,
                 progress=False, stop_after=2)
    (tmp_path / CONFIG_FILE).unlink()
    with pytest.raises(RunFolderError, match="checkpoint of another run"):
        train_policy(spec("icrt", "mlp", ["train.steps=4"]), run_dir=tmp_path, demos=demos,
                     progress=False)


def test_a_corrupt_config_is_set_aside(tmp_path, demos):
    s = spec("icrt", "mlp", ["train.steps=2"])
    train_policy(s, run_dir=tmp_path, demos=demos, progress=False, stop_after=1)
    (tmp_path / CONFIG_FILE).write_text("{not json")
    (tmp_path / ".checkpoint.pt.123.tmp").write_bytes(b"half")
    with pytest.warns(DamagedFileWarning):
        result = train_policy(s, run_dir=tmp_path, demos=demos, progress=False)
    assert result.metrics["steps"] == 2
    assert json.loads((tmp_path / CONFIG_FILE).read_text())["key"] == s.key()
    assert not list(tmp_path.glob(".*.tmp")), "stale temporary files are cleaned"


def test_unusable_run_folders_are_named(tmp_path, demos):
    s = spec("icrt", "mlp", ["train.steps=1"])
    (tmp_path / "file").write_text("")
    with pytest.raises(RunFolderError, match="is a file"):
        train_policy(s, run_dir=tmp_path / "file", demos=demos, progress=False)
    if os.getuid() != 0:  # root writes anywhere
        (tmp_path / "ro").mkdir(mode=0o500)
        with pytest.raises(RunFolderError, match="cannot write"):
            train_policy(s, run_dir=tmp_path / "ro", demos=demos, progress=False)
    with pytest.raises(ValueError, match="train.steps (counts something and )?must be at least 1"):
        train_policy(spec("icrt", "mlp", ["train.steps=0"]), run_dir=None, demos=demos)


def test_warmup_then_cosine_to_zero():
    f = cosine_schedule(warmup=4, total=20)
    assert [f(s) for s in range(4)] == [0.25, 0.5, 0.75, 1.0]
    values = [f(s) for s in range(4, 21)]
    assert values[0] == pytest.approx(1.0) and values[-1] == pytest.approx(0.0, abs=1e-12)
    assert all(a >= b for a, b in zip(values, values[1:], strict=False))


def test_ema_weights_are_the_returned_policy(demos):
    plain = train_policy(spec("bc_transformer", None, ["train.steps=5"]), demos=demos,
                         progress=False)
    averaged = train_policy(spec("bc_transformer", None, ["train.steps=5", "train.ema_decay=0.5"]),
                            demos=demos, progress=False)
    assert not states_equal(plain.policy, averaged.policy)


def test_train_cli_writes_run_and_record(tmp_path, demos, monkeypatch):
    import icil_paper.train.cli as train_cli
    from icil_paper.results import ResultsStore
    from icil_paper.train.cli import main

    monkeypatch.setattr(train_cli, "training_demos", lambda *a, **k: demos)
    args = ["--preset", "smoke", "--policy", "act", "--tokenizer", "lipvq", "--tasks",
            "kitchen/open_drawer", "--run-dir", str(tmp_path / "run"), "--quiet"]
    assert main(args + ["--set", "train.steps=3"]) == 0
    assert (tmp_path / "run" / POLICY_FILE).exists()
    table = ResultsStore("smoke").table("train")
    assert list(table["name"]) == ["act+lipvq__kitchen-open_drawer__generated__seed0"]
    assert table["steps"].iloc[0] == 3


def test_set_changes_the_run_folder_and_record(tmp_path, demos, monkeypatch):
    import icil_paper.train.cli as train_cli
    from icil_paper.results import ResultsStore
    from icil_paper.train.cli import main

    monkeypatch.setattr(train_cli, "training_demos", lambda *a, **k: demos)
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path))
    base = ["--preset", "smoke", "--tasks", "kitchen/open_drawer", "--quiet"]
    assert main(base + ["--set", "train.steps=3"]) == 0
    assert main(base + ["--set", "train.steps=4"]) == 0
    folders = sorted(p.name for p in (tmp_path / "smoke").iterdir())
    assert len(folders) == 2 and folders[0] != folders[1]
    assert sorted(ResultsStore("smoke").table("train")["steps"]) == [3, 4]


def test_run_dir_follows_the_run_spec(tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_RUNS", str(tmp_path))
    base = run_dir_for(spec("icrt", "lipvq"), "smoke")
    assert base.parent == tmp_path / "smoke"
    assert base.name.startswith("icrt+lipvq__synthetic__generated__seed0__")
    assert run_dir_for(spec("icrt", "lipvq"), "smoke") == base  # stable
    assert run_dir_for(spec("icrt", "lipvq", ["eval.episodes_per_task=7", "train.log_every=3",
                                              "data.workers=3"]), "smoke") == base
    for changed in (["train.steps=6"], ["policies.icrt.d_model=64"],
                    ["tokenizers.lipvq.codebook_size=32"], ["data.demos_per_task=3"]):
        assert run_dir_for(spec("icrt", "lipvq", changed), "smoke") != base, changed
    assert run_dir_for(spec("icrt", "lipvq", seed=1), "smoke") != base
    monkeypatch.setenv("ICIL_RUNS", "")
    assert run_dir_for(spec("icrt", "lipvq"), "smoke").parent.name == "smoke"
    assert "runs" in run_dir_for(spec("icrt", "lipvq"), "smoke").parts


def test_specs_round_trip_through_json():
    from icil_paper.runspec import RunSpec

    for policy, tokenizer in (("icrt", "lipvq"), ("act", None), ("act", "fast"), ("mcr", None)):
        s = spec(policy, tokenizer)
        back = RunSpec.from_dict(json.loads(json.dumps(s.to_dict())))
        assert back == s and back.key() == s.key()
        assert dataclasses.replace(s, seed=3).key() != s.key()


def test_train_command_trains_on_a_robomimic_file(tmp_path):
    """`icil-paper train --dataset FILE` on a file as robosuite / robomimic tools write it."""
    import h5py

    from icil_paper.cli import main

    rng = np.random.default_rng(0)
    path = tmp_path / "lift.hdf5"
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "Lift", "type": 1, "env_kwargs": {}})
        for i, T in enumerate((12, 9, 10)):
            g = data.create_group(f"demo_{i}")
            g.attrs["num_samples"] = T
            g.create_dataset("actions", data=rng.uniform(-1, 1, (T, 7)))
            for key, width in (("robot0_eef_pos", 3), ("robot0_eef_quat", 4),
                               ("robot0_gripper_qpos", 2), ("object", 10)):
                g.create_dataset(f"obs/{key}", data=rng.normal(size=(T, width)))
    run = tmp_path / "run"
    assert main(["train", "--preset", "smoke", "--dataset", str(path), "--run-dir", str(run),
                 "--set", "train.steps=2", "--quiet"]) == 0
    policy = load_policy(run)
    assert policy.obs_spec.lowdim_dim == 19 and policy.action_dim == 7
    config = json.loads((run / CONFIG_FILE).read_text())
    assert config["spec"]["data"]["dataset"] == str(path.resolve())
    assert len(config["spec"]["data"]["dataset_sha256"]) == 64
    code = main(["train", "--preset", "smoke", "--dataset", str(tmp_path / "none.hdf5")])
    assert code == 2
