"""Demonstration data: HDF5 round trip, validation errors, robomimic files, sources, resumable
generation (with a simulator-free fake suite; ManiSkill generation is in test_maniskill.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

import fake_suite
import icil_paper.sim as sim
from icil_paper.config import get_preset
from icil_paper.data import (
    EVAL_SEED_BASE,
    DatasetError,
    Demo,
    HumanLikeOperator,
    demo_path,
    demo_seed,
    ensure_demos,
    expert_rollout,
    file_info,
    generate,
    load_demos,
    read_masks,
    train_valid_split,
    write_demos,
)
from icil_paper.data import cli as data_cli
from icil_paper.data.generate import _Job, generate_one, parts_dir, shard_path
from icil_paper.data.sources import ATTEMPT_STRIDE, ExpertSource
from icil_paper.data.stats import action_least_energy_per_step, data_set_stats, keep_rate
from icil_paper.seeding import data_set_seed

TASK = "kitchen/reach_a"


@pytest.fixture
def fake_kitchen(monkeypatch, tmp_path):
    fake_suite.use(monkeypatch)
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    return tmp_path / "data"


def _demo(T=5, seed=0, images=False, task="kitchen/reach_a"):
    rng = np.random.default_rng(seed)
    obs = {"proprio": rng.normal(size=(T, 9)).astype(np.float32),
           "object": rng.normal(size=(T, 6)).astype(np.float32)}
    if images:
        obs["rgb"] = rng.integers(0, 255, (T, 2, 4, 4, 3), dtype=np.uint8)
        obs["depth"] = rng.random((T, 2, 4, 4)).astype(np.float32)
    return Demo(actions=rng.uniform(-1, 1, (T, 7)).astype(np.float32), obs=obs, task=task,
                source="generated", instruction="reach", seed=seed,
                states=rng.normal(size=(T, 4)).astype(np.float32),
                rewards=np.zeros(T, np.float32))


# ----------------------------------------------------------------------------- file format
def test_written_data_set_round_trips(tmp_path):
    demos = [_demo(T=4 + i, seed=i, images=True) for i in range(12)]
    path = write_demos(tmp_path / "d.hdf5", demos, file_attrs={"task": TASK, "env_args": {
        "env_name": TASK}}, split_seed=3)
    loaded = load_demos(path, action_dim=7)
    assert [d.name for d in loaded] == [f"demo_{i}" for i in range(12)]  # numeric order
    for a, b in zip(demos, loaded, strict=True):
        assert np.array_equal(a.actions, b.actions) and np.array_equal(a.states, b.states)
        assert set(b.obs) == {"proprio", "object", "rgb", "depth"}
        for k in a.obs:
            assert np.array_equal(a.obs[k], b.obs[k]) and a.obs[k].dtype == b.obs[k].dtype
        assert (b.task, b.source, b.instruction, b.seed) == (a.task, a.source, "reach", a.seed)
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's 0600
    masks = read_masks(path)
    assert len(masks["valid"]) == 1 and len(masks["train"]) == 11
    assert set(masks["train"]).isdisjoint(masks["valid"])
    info = file_info(path)
    assert info["env_args"] == {"env_name": TASK} and info["total"] == sum(map(len, demos))
    with h5py.File(path) as f:  # robomimic's per-demo attributes
        assert f["data/demo_3"].attrs["num_samples"] == 7
        assert json.loads(f["data/demo_3"].attrs["ep_meta"])["lang"] == "reach"
        assert f["data/demo_3/dones"][-1] == 1
    assert len(load_demos(path, limit=3, images=False)) == 3
    assert "rgb" not in load_demos(path, limit=1, images=False)[0].obs


def test_layout_is_robomimics_with_next_obs_cameras_checksums(tmp_path):
    demos = [_demo(T=5, seed=i, images=True) for i in range(3)]
    demos[0].cameras = ("agentview", "wrist")
    demos[0].final_obs = {k: v[-1] + 1 for k, v in demos[0].obs.items()}
    path = write_demos(tmp_path / "d.hdf5", demos, file_attrs={"control_freq": 20})
    with h5py.File(path) as f:
        g = f["data/demo_0"]
        assert f["data"].attrs["format"] == "icil_paper/2" and f["data"].attrs["control_freq"] == 20
        assert set(g["obs"]) == set(g["next_obs"]) == {
            "proprio", "object", "agentview_image", "wrist_image", "agentview_depth", "wrist_depth"}
        assert g["obs/wrist_image"].shape == (5, 4, 4, 3) and g["obs/wrist_depth"].shape == (5, 4, 4, 1)
        assert np.array_equal(g["obs/wrist_image"][()], demos[0].obs["rgb"][:, 1])
        # next_obs[t] = obs[t + 1]; its last row is the observation after the last action
        assert np.array_equal(g["next_obs/proprio"][:-1], g["obs/proprio"][1:])
        assert np.array_equal(g["next_obs/proprio"][-1], demos[0].final_obs["proprio"])
        assert np.array_equal(f["data/demo_1/next_obs/object"][-1], demos[1].obs["object"][-1])
        assert g["states"].dtype == np.float64
        datasets = []
        f.visititems(lambda n, o: datasets.append(o) if isinstance(o, h5py.Dataset)
                     and n.startswith("data/") else None)
        assert datasets and all(d.fletcher32 for d in datasets)
    loaded = load_demos(path)
    assert loaded[0].cameras == ("agentview", "wrist") and loaded[1].cameras == ("camera0", "camera1")
    assert loaded[0].states.dtype == np.float64
    for k, v in demos[0].final_obs.items():
        assert np.array_equal(loaded[0].final_obs[k], v.astype(loaded[0].obs[k].dtype))
    again = write_demos(tmp_path / "again.hdf5", loaded)  # a loaded demo writes back the same
    with h5py.File(path) as f, h5py.File(again) as g:
        for key in f["data/demo_0/next_obs"]:
            assert np.array_equal(f["data/demo_0/next_obs"][key][()],
                                  g["data/demo_0/next_obs"][key][()])


def _write_version_1(path, demos):
    """A data set in the first layout: stacked obs/rgb and obs/depth, no next_obs."""
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["format"] = "icil_paper/1"
        data.attrs["env_args"] = json.dumps({"env_name": TASK, "type": "icil_paper"})
        for i, d in enumerate(demos):
            g = data.create_group(f"demo_{i}")
            g.create_dataset("actions", data=d.actions)
            for k, v in d.obs.items():
                g.create_dataset(f"obs/{k}", data=v)
            g.create_dataset("states", data=d.states.astype(np.float32))
            g.attrs.update({"num_samples": len(d), "task": d.task, "source": d.source,
                            "instruction": d.instruction, "seed": d.seed, "attempt": 0})


def test_version_1_files_load_and_are_rewritten_when_merged(tmp_path):
    from icil_paper.data.hdf5 import merge_demo_files

    old = [_demo(T=4 + i, seed=i, images=True) for i in range(2)]
    _write_version_1(tmp_path / "old.hdf5", old)
    loaded = load_demos(tmp_path / "old.hdf5", action_dim=7)
    for a, b in zip(old, loaded, strict=True):
        for k in a.obs:
            assert np.array_equal(a.obs[k], b.obs[k]) and a.obs[k].dtype == b.obs[k].dtype
        assert b.final_obs is None and b.meta == {"attempt": 0} and b.task == TASK
    new = write_demos(tmp_path / "shard.hdf5", [_demo(T=6, seed=9, images=True)],
                      names=["demo_2"])
    merged = merge_demo_files(tmp_path / "old.hdf5", [(tmp_path / "old.hdf5", "demo_0", "demo_0"),
                                                      (tmp_path / "old.hdf5", "demo_1", "demo_1"),
                                                      (new, "demo_2", "demo_2")], {"task": TASK})
    with h5py.File(merged) as f:
        assert all("next_obs" in f["data"][n] and "camera0_image" in f["data"][n]["obs"]
                   for n in ("demo_0", "demo_1", "demo_2"))
        assert f["data/demo_0"].attrs["attempt"] == 0
    after = load_demos(merged)
    assert [len(d) for d in after] == [4, 5, 6]
    for a, b in zip(loaded, after[:2], strict=True):
        assert all(np.array_equal(a.obs[k], b.obs[k]) for k in a.obs)
        assert np.array_equal(a.actions, b.actions) and np.array_equal(a.states, b.states)


def test_limit_returns_exactly_the_first_demos(tmp_path):
    demos = [_demo(T=3 + i % 4, seed=i) for i in range(12)]
    path = write_demos(tmp_path / "d.hdf5", demos)
    for n in (1, 3, 10, 12):
        loaded = load_demos(path, limit=n)
        assert [d.name for d in loaded] == [f"demo_{i}" for i in range(n)]
        assert all(np.array_equal(d.actions, demos[i].actions) for i, d in enumerate(loaded))
    with pytest.raises(DatasetError, match="holds 12 demos, 13 were asked for"):
        load_demos(path, limit=13)
    for bad in (0, -1, 2.5, True, "3"):
        with pytest.raises(ValueError, match="limit must be"):
            load_demos(path, limit=bad)


def test_action_widths_are_checked_across_demos_and_against_the_file(tmp_path):
    demos = [_demo(seed=i) for i in range(3)]
    demos[2].actions = demos[2].actions[:, :6]
    path = write_demos(tmp_path / "mixed.hdf5", demos)
    with pytest.raises(DatasetError, match="demo 'demo_2': action dimension 6 differs from the "
                                           r"file's first demo \(7\)") as err:
        load_demos(path)
    assert str(path) in str(err.value)
    narrow = [_demo(seed=i) for i in range(2)]
    for d in narrow:
        d.actions = d.actions[:, :6]
    path = write_demos(tmp_path / "narrow.hdf5", narrow, file_attrs={"action_dim": 7})
    with pytest.raises(DatasetError, match="demo 'demo_0': action dimension 6 does not match "
                                           "the file's action_dim attribute 7"):
        load_demos(path)


def _flip_byte(path, dataset):
    with h5py.File(path) as f:
        info = f[dataset].id.get_chunk_info(0)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        byte = fh.read(1)
        fh.seek(-1, 1)
        fh.write(bytes([byte[0] ^ 0x10]))


def test_flipped_bytes_and_damaged_files_raise_dataset_error(tmp_path):
    from icil_paper.data import verify_file

    path = write_demos(tmp_path / "d.hdf5", [_demo(seed=i) for i in range(3)])
    _flip_byte(path, "data/demo_1/actions")
    with pytest.raises(DatasetError, match="demo 'demo_1': cannot read actions: the file is "
                                           "damaged .*[Cc]hecksum"):
        load_demos(path)
    with pytest.raises(DatasetError, match="data/demo_1/actions cannot be read: the file is "
                                           "damaged"):
        verify_file(path)
    whole = write_demos(tmp_path / "whole.hdf5", [_demo(seed=i) for i in range(3)])
    cut = tmp_path / "cut.hdf5"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    with pytest.raises(DatasetError) as err:
        load_demos(cut)
    assert str(err.value).startswith(f"{cut}: ")
    with pytest.raises(DatasetError, match="is a folder"):
        load_demos(tmp_path)


def test_a_file_is_read_once_until_it_changes(tmp_path, monkeypatch):
    from icil_paper.data import memo, verify_file

    path = write_demos(tmp_path / "d.hdf5", [_demo(seed=i) for i in range(3)])
    assert load_demos(path) and memo.signature(path) is None  # just written: read afresh
    monkeypatch.setattr(memo, "SETTLE_S", 0.0)
    monkeypatch.setattr(memo, "_KEPT", type(memo._KEPT)())
    first = load_demos(path)
    assert verify_file(path)["demos"] == ["demo_0", "demo_1", "demo_2"]
    first[0].actions[:] = 9.0  # a caller's changes stay its own
    first[1].obs["proprio"] += 1.0
    again = load_demos(path)
    assert len(memo._KEPT) == 2
    for a, b in zip([_demo(seed=i) for i in range(3)], again, strict=True):
        assert np.array_equal(a.actions, b.actions) and np.array_equal(a.obs["proprio"],
                                                                       b.obs["proprio"])
    assert load_demos(path, limit=1)[0].name == "demo_0" and len(memo._KEPT) == 3
    write_demos(path, [_demo(seed=7)])  # replaced: read afresh, damage found again
    assert np.array_equal(load_demos(path)[0].actions, _demo(seed=7).actions)
    _flip_byte(path, "data/demo_0/actions")
    os.utime(path, ns=(0, 0))  # even under its old modification time (its change time moves)
    with pytest.raises(DatasetError, match="damaged"):
        load_demos(path)
    with pytest.raises(DatasetError, match="damaged"):
        verify_file(path)


def test_train_valid_split_is_seeded_and_disjoint():
    names = [f"demo_{i}" for i in range(20)]
    a, b = train_valid_split(names, 0.2, seed=1), train_valid_split(names, 0.2, seed=1)
    assert a == b and len(a["valid"]) == 4 and sorted(a["train"] + a["valid"]) == sorted(names)
    assert train_valid_split(names, 0.2, seed=2)["valid"] != a["valid"]
    with pytest.raises(ValueError):
        train_valid_split(names, 1.0)


def _corrupt(path, edit):
    with h5py.File(path, "a") as f:
        edit(f)


@pytest.mark.parametrize("edit, action_dim, message", [
    (lambda f: f["data/demo_1"].__delitem__("actions"), None, "missing key 'actions'"),
    (lambda f: f["data/demo_1/obs"].__delitem__("proprio"), None, "missing key 'obs/proprio'"),
    (lambda f: f["data/demo_1"].__delitem__("obs"), None, "missing key 'obs'"),
    (None, 6, "demo 'demo_0': action dimension 7 does not match the expected 6"),
    (lambda f: f["data/demo_1/actions"].__setitem__((2, 3), np.nan), None, "actions has NaN"),
    (lambda f: f["data/demo_1/obs/object"].__setitem__((0, 0), np.inf), None,
     "obs/object has NaN"),
    (lambda f: (f["data/demo_1/obs"].__delitem__("object"),
                f["data/demo_1/obs"].create_dataset("object", data=np.zeros((3, 6)))),
     None, "obs/object has 3 steps but actions have 5"),
    (lambda f: (f["data/demo_1/obs"].__delitem__("camera1_image"),
                f["data/demo_1/obs"].create_dataset("camera1_image",
                                                    data=np.zeros((5, 4, 4), np.uint8))),
     None, r"obs/camera1_image must be \(T, H, W, 3\)"),
    (lambda f: (f["data/demo_1/obs"].__delitem__("camera1_image"),
                f["data/demo_1/obs"].create_dataset("camera1_image",
                                                    data=np.zeros((5, 6, 6, 3), np.uint8))),
     None, r"cameras obs/camera0_image, obs/camera1_image have different image shapes"),
    (lambda f: (f["data/demo_1/obs"].__delitem__("object"),
                f["data/demo_1/obs"].create_dataset("object", data=np.zeros((5, 4), np.float32))),
     None, r"widths \(9, 4\) differ from the file's first demo \(9, 6\)"),
    (lambda f: f["data/demo_1"].__delitem__("states") or f["data/demo_1"].create_dataset(
        "states", data=np.zeros((2, 4))), None, "states have 2 steps"),
])
def test_loader_errors_name_file_demo_and_problem(tmp_path, edit, action_dim, message):
    path = write_demos(tmp_path / "bad.hdf5", [_demo(seed=i, images=True) for i in range(3)])
    if edit is not None:
        _corrupt(path, edit)
    with pytest.raises(DatasetError, match=message) as err:
        load_demos(path, action_dim=action_dim)
    assert str(err.value).startswith(f"{path}: demo 'demo_")
    if action_dim is None:
        assert "demo 'demo_1'" in str(err.value)


def test_loader_errors_on_unusable_files(tmp_path):
    with pytest.raises(DatasetError, match="file not found"):
        load_demos(tmp_path / "missing.hdf5")
    (tmp_path / "text.hdf5").write_text("not hdf5")
    with pytest.raises(DatasetError, match="not a readable HDF5 file"):
        load_demos(tmp_path / "text.hdf5")
    with h5py.File(tmp_path / "nodata.hdf5", "w") as f:
        f.create_group("something")
    with pytest.raises(DatasetError, match="no 'data' group"):
        load_demos(tmp_path / "nodata.hdf5")
    with h5py.File(tmp_path / "empty.hdf5", "w") as f:
        f.create_group("data")
    with pytest.raises(DatasetError, match="no demos"):
        load_demos(tmp_path / "empty.hdf5")


def test_reads_robomimic_files(tmp_path):
    """A file as robosuite / robomimic tools write it (RoboCasa, MimicGen)."""
    path = tmp_path / "robomimic.hdf5"
    rng = np.random.default_rng(0)
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "PnPCounterToCab", "type": 1,
                                             "env_kwargs": {}})
        for i, T in enumerate((6, 4)):
            g = data.create_group(f"demo_{i}")
            g.attrs["num_samples"] = T
            g.attrs["ep_meta"] = json.dumps({"lang": "pick the apple from the counter"})
            g.create_dataset("actions", data=rng.uniform(-1, 1, (T, 7)))
            o = g.create_group("obs")
            o.create_dataset("robot0_eef_pos", data=rng.normal(size=(T, 3)))
            o.create_dataset("robot0_eef_quat", data=rng.normal(size=(T, 4)))
            o.create_dataset("robot0_gripper_qpos", data=rng.normal(size=(T, 2)))
            o.create_dataset("object", data=rng.normal(size=(T, 14)))
            o.create_dataset("robot0_joint_pos", data=rng.normal(size=(T, 7)))
            o.create_dataset("agentview_image", data=np.zeros((T, 8, 8, 3), np.uint8))
            o.create_dataset("robot0_eye_in_hand_image", data=np.ones((T, 8, 8, 3), np.uint8))
            o.create_dataset("agentview_depth", data=np.ones((T, 8, 8, 1), np.float32))
            o.create_dataset("robot0_eye_in_hand_depth", data=np.ones((T, 8, 8, 1)))
            g.create_dataset("states", data=rng.normal(size=(T, 30)))
    with pytest.warns(UserWarning, match="observation keys not used: robot0_joint_pos "):
        demos = load_demos(path, action_dim=7)
    d = demos[0]
    with h5py.File(path) as f:
        o = f["data/demo_0/obs"]
        expected = np.concatenate([o["robot0_eef_pos"][()], o["robot0_eef_quat"][()],
                                   o["robot0_gripper_qpos"][()]], axis=1)
    assert np.allclose(d.obs["proprio"], expected) and d.obs["proprio"].dtype == np.float32
    assert d.obs["object"].shape == (6, 14)
    assert d.obs["rgb"].shape == (6, 2, 8, 8, 3)
    assert d.obs["rgb"][:, 0].max() == 0 and d.obs["rgb"][:, 1].min() == 1  # sorted cameras
    assert d.obs["depth"].shape == (6, 2, 8, 8)
    assert (d.task, d.source, d.seed) == ("PnPCounterToCab", "robomimic", -1)
    assert d.instruction == "pick the apple from the counter"
    with pytest.raises(DatasetError, match="action dimension 7 does not match the expected 12"):
        load_demos(path, action_dim=12, obs_keys=["robot0_eef_pos", "object"])


# ----------------------------------------------------------------------------- sources
def test_demo_seeds_are_unique_and_below_evaluation_seeds():
    seeds = {demo_seed(5, s, i, a) for s in ("generated", "human") for i in range(0, 2000, 7)
             for a in range(20)}
    assert len(seeds) == 2 * len(range(0, 2000, 7)) * 20
    assert max(seeds) < EVAL_SEED_BASE
    assert demo_seed(0, "generated", 3, 1) == 3 + ATTEMPT_STRIDE


def test_human_source_is_seeded_noisy_and_still_succeeds(fake_kitchen):
    env = sim.make_env(TASK, horizon=200)
    expert = sim.make_expert(TASK)
    generated, ok = expert_rollout(env, ExpertSource(expert), seed=11)
    assert ok and generated.states.dtype == np.float64
    assert generated.final_obs["object"].shape == generated.obs["object"].shape[1:]
    human = HumanLikeOperator(expert, action_scale=(0.02, 0.5))
    a, ok_a = expert_rollout(env, human, seed=11, source="human")
    events = dict(human.events)
    b, ok_b = expert_rollout(env, human, seed=11, source="human")
    c, _ = expert_rollout(env, human, seed=12, source="human")
    assert ok_a and ok_b and a.source == "human"
    assert np.array_equal(a.actions, b.actions)  # same seed, same demo
    assert a.actions.shape != c.actions.shape or not np.allclose(a.actions, c.actions)
    assert np.all(np.abs(a.actions) <= 1)
    # over several scenes: hesitations and lower speed make demos longer, noise less smooth
    pairs = [(expert_rollout(env, ExpertSource(expert), seed=s)[0],
              expert_rollout(env, human, seed=s, source="human")[0]) for s in (20, 21, 22, 24, 25, 26)]
    assert np.mean([len(h) for _, h in pairs]) > 1.1 * np.mean([len(g) for g, _ in pairs])
    assert (np.mean([action_least_energy_per_step(h.actions) for _, h in pairs])
            > 2 * np.mean([action_least_energy_per_step(g.actions) for g, _ in pairs]))
    # over many steps every behaviour of the operator model shows up
    long_env = sim.make_env(TASK, horizon=400)
    long_env.reset(seed=4)
    human.reset(long_env, long_env._obs(), seed=4)
    far = {"proprio": np.zeros(9, np.float32), "object": np.full(6, 5.0, np.float32)}
    for _ in range(400):
        human.act(far)
    assert human.events["pauses"] > 3 and human.events["overshoots"] > 2
    assert set(events) == {"pauses", "overshoots"}


# ----------------------------------------------------------------------------- generation
def test_empty_icil_data_counts_as_unset(monkeypatch, tmp_path):
    from icil_paper.data import data_root
    from icil_paper.setup.provenance import REPO_ROOT

    for value in ("", "   "):
        monkeypatch.setenv("ICIL_DATA", value)
        assert data_root() == REPO_ROOT / "data"
    monkeypatch.setenv("ICIL_DATA", str(tmp_path))
    assert data_root() == tmp_path


def test_the_data_folder_travels_in_the_preset_not_the_environment(monkeypatch, tmp_path):
    """A library user's preset says where its data lives; $ICIL_DATA only fills the presets
    that `get_preset` returns, and the folder is no part of any key."""
    from icil_paper.config import Preset, get_preset
    from icil_paper.data import data_root
    from icil_paper.runspec import run_spec
    from icil_paper.setup.provenance import REPO_ROOT

    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "from_env"))
    mine = Preset(name="smoke").replace(data={"root": str(tmp_path / "mine")})
    assert data_root(mine) == tmp_path / "mine"
    assert demo_path(mine, TASK, "generated").is_relative_to(tmp_path / "mine")
    assert data_root(Preset(name="smoke")) == REPO_ROOT / "data"
    assert get_preset("smoke").data.root == str(tmp_path / "from_env")
    spec = run_spec(get_preset("smoke"), policy="icrt", tokenizer="lipvq", tasks=[TASK])
    moved = run_spec(get_preset("smoke").replace(data={"root": "/elsewhere"}), policy="icrt",
                     tokenizer="lipvq", tasks=[TASK])
    assert spec.key() == moved.key()


def test_generated_data_sets_say_how_to_build_their_env(fake_kitchen):
    path = ensure_demos("smoke", TASK, "generated", n=1, workers=1, progress=False)
    info = file_info(path)
    args = info["env_args"]
    assert args["env_name"] == sim.gym_id(TASK) == "icil_paper/kitchen-reach_a-v0"
    assert args["type"] == 2 and args["env_kwargs"] == {"obs": "state"}  # robomimic's gym type
    assert args["icil_paper"]["task"] == TASK and "rollout.enabled=False" in args[
        "icil_paper"]["robomimic"]
    assert info["control_freq"] == 20 and info["action_dim"] == 7
    demo = load_demos(path)[0]
    env = sim.make_env(args["icil_paper"]["task"], **args["env_kwargs"])
    replay = expert_rollout(env, _Replay(demo.actions), seed=demo.seed)[0]
    assert np.array_equal(replay.obs["object"], demo.obs["object"])
    assert np.array_equal(replay.final_obs["proprio"], demo.final_obs["proprio"])


class _Replay:
    def __init__(self, actions):
        self.actions = actions

    def reset(self, env, obs, seed=None):
        self.t = 0

    def act(self, obs):
        self.t += 1
        return self.actions[self.t - 1]


def test_damaged_data_set_and_shard_are_set_aside_and_regenerated(fake_kitchen):
    reference = load_demos(ensure_demos("smoke", TASK, "generated", n=3, workers=1,
                                        progress=False, seed=100))
    path = demo_path("smoke", TASK, "generated")
    _flip_byte(path, "data/demo_2/actions")
    damaged = path.read_bytes()
    with pytest.warns(UserWarning, match="cannot be read: the file is damaged.*moved it to"):
        ensure_demos("smoke", TASK, "generated", n=3, workers=1, progress=False, seed=100)
    aside = list(path.parent.glob("generated.hdf5.corrupt-*"))
    assert len(aside) == 1 and aside[0].read_bytes() == damaged  # kept, never deleted
    regenerated = load_demos(path)
    assert [d.seed for d in regenerated] == [d.seed for d in reference]
    assert all(np.array_equal(a.actions, b.actions) for a, b in zip(reference, regenerated,
                                                                    strict=True))
    # a damaged shard: set aside beside the data set (the parts folder is removed after merging)
    attrs = {"task": TASK, "source": "generated", "obs_kind": "state", "base_seed": 100}
    for i in (3, 4):
        generate_one(_Job(TASK, "generated", "state", i, 100, str(shard_path(path, i)), attrs,
                          {}))
    shard = shard_path(path, 4)
    shard.write_bytes(shard.read_bytes()[:200])
    with pytest.warns(UserWarning, match="demo 4 will be generated again"):
        ensure_demos("smoke", TASK, "generated", n=5, workers=1, progress=False, seed=100)
    assert len(list(path.parent.glob("demo_000004.hdf5.corrupt-*"))) == 1
    five = load_demos(path)
    assert [d.name for d in five] == [f"demo_{i}" for i in range(5)]
    # a second damage at once gets its own name (the first is kept)
    for _ in range(2):
        path.write_bytes(b"not hdf5")
        with pytest.warns(UserWarning, match="not a readable HDF5 file"):
            ensure_demos("smoke", TASK, "generated", n=1, workers=1, progress=False, seed=100)
    assert len(list(path.parent.glob("generated.hdf5.corrupt-*"))) == 3


def test_damaged_images_are_found_by_the_demos_command(fake_kitchen, capsys):
    """Runs inside training and evaluation skip reading the image arrays back (their cost);
    `icil-paper demos` reads them, sets a damaged file aside and regenerates it."""
    path = ensure_demos("smoke", TASK, "generated", n=2, workers=1, progress=False, obs="rgb")
    reference = load_demos(path)
    _flip_byte(path, "data/demo_1/obs/cam_image")
    with pytest.raises(DatasetError, match="demo 'demo_1': cannot read obs/cam_image: the file "
                                           "is damaged"):
        load_demos(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ensure_demos("smoke", TASK, "generated", n=2, workers=1, progress=False, obs="rgb")
    with pytest.warns(UserWarning, match="cam_image cannot be read"):
        assert data_cli.main(["--task", TASK, "--n", "2", "--obs", "rgb", "--preset", "smoke",
                              "--workers", "1", "--no-progress"]) == 0
    assert len(list(path.parent.glob(f"{path.name}.corrupt-*"))) == 1
    again = load_demos(path)
    assert all(np.array_equal(a.obs["rgb"], b.obs["rgb"]) for a, b in zip(reference, again,
                                                                           strict=True))


def test_demos_cli_refuses_bad_numbers_before_any_work(fake_kitchen, capsys):
    episodes = fake_suite.ReachExpert.episodes
    for args in (["--n", "0"], ["--n", "-2"], ["--workers", "0"], ["--seed", "-1"]):
        rc = data_cli.main(["--task", TASK, "--preset", "smoke", "--no-progress", *args])
        err = capsys.readouterr().err
        assert rc == 2 and len(err.strip().splitlines()) == 1 and args[0] in err
    assert fake_suite.ReachExpert.episodes == episodes and not fake_kitchen.exists()
    with pytest.raises(ValueError, match="at least 1"):
        ensure_demos("smoke", TASK, "generated", n=0, progress=False)


def test_ensure_demos_generates_resumes_and_extends(fake_kitchen):
    path = demo_path("smoke", TASK, "generated")
    assert path == fake_kitchen / "smoke" / "kitchen" / "reach_a" / "generated.hdf5"
    assert demo_path("smoke", TASK, "human", obs="rgb").name == "human_rgb.hdf5"
    ref = ensure_demos("smoke", TASK, "generated", n=4, workers=1, progress=False,
                       seed=100)
    assert ref == path
    reference = load_demos(ref)
    # demo 3's first seed (100 + 3 = 103) is unsolvable; it moves to its next attempt's seed
    assert [d.seed for d in reference] == [100, 101, 102, 103 + ATTEMPT_STRIDE]
    assert keep_rate(reference) == 4 / 5  # five episodes made four demos
    rows = data_set_stats(reference)
    assert [r["attempts"] for r in rows] == [1, 1, 1, 2]
    assert all(r["length"] == len(d) and r["task"] == TASK for r, d in zip(rows, reference,
                                                                           strict=True))
    reference_bytes = {d.name: d.actions.copy() for d in reference}
    os.replace(ref, ref.with_suffix(".ref"))

    # an interrupted run: demos 0 and 2 finished (shards), then the process died
    attrs = {"task": TASK, "source": "generated", "obs_kind": "state", "base_seed": 100}
    for i in (0, 2):
        generate_one(_Job(TASK, "generated", "state", i, 100, str(shard_path(path, i)), attrs,
                          {}))
    (parts_dir(path) / ".demo_000001.hdf5.x.tmp").write_bytes(b"half a file")
    episodes = fake_suite.ReachExpert.episodes
    ensure_demos("smoke", TASK, "generated", n=4, workers=1, progress=False, seed=100)
    assert fake_suite.ReachExpert.episodes - episodes == 3  # demos 1 and 3 (two tries)
    assert not parts_dir(path).exists()
    resumed = load_demos(path)
    assert [d.name for d in resumed] == list(reference_bytes)
    for d in resumed:
        assert np.array_equal(d.actions, reference_bytes[d.name])

    # nothing missing: no episode is run; asking for more keeps the first demos as they were
    episodes = fake_suite.ReachExpert.episodes
    ensure_demos("smoke", TASK, "generated", n=3, workers=1, progress=False, seed=100)
    assert fake_suite.ReachExpert.episodes == episodes
    ensure_demos("smoke", TASK, "generated", n=6, workers=1, progress=False, seed=100)
    more = load_demos(path)
    assert len(more) == 6
    for d in more[:4]:
        assert np.array_equal(d.actions, reference_bytes[d.name])
    with pytest.raises(DatasetError, match="base_seed"):
        ensure_demos("smoke", TASK, "generated", n=7, workers=1, progress=False, seed=5)


def test_killed_generation_keeps_finished_demos(fake_kitchen):
    """Kill a real `icil-paper demos` process mid-run, re-run it, compare with a clean run."""
    tests_dir = Path(__file__).parent
    src_dir = Path(sim.__file__).parents[2]
    code = ("import sys, fake_suite; fake_suite.install(step_delay={delay}); "
            "from icil_paper.data.cli import main; "
            "sys.exit(main(['--task', '{task}', '--n', '6', '--preset', 'smoke', "
            "'--workers', '1', '--no-progress', '--seed', '0']))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tests_dir), str(src_dir)]),
           "ICIL_DATA": str(fake_kitchen)}
    path = demo_path("smoke", TASK, "generated")
    slow = subprocess.Popen([sys.executable, "-c", code.format(delay=0.02, task=TASK)], env=env)
    deadline = time.time() + 60
    while time.time() < deadline and len(list(parts_dir(path).glob("demo_*.hdf5"))) < 2:
        time.sleep(0.05)
    slow.kill()
    slow.wait()
    finished = sorted(p.name for p in parts_dir(path).glob("demo_*.hdf5"))
    assert len(finished) >= 2 and not path.exists()
    done = subprocess.run([sys.executable, "-c", code.format(delay=0.0, task=TASK)], env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    resumed = load_demos(path)
    os.replace(path, path.with_suffix(".resumed"))
    clean = subprocess.run([sys.executable, "-c", code.format(delay=0.0, task=TASK)], env=env,
                           capture_output=True, text=True, timeout=120)
    assert clean.returncode == 0, clean.stderr
    fresh = load_demos(path)
    assert [d.seed for d in resumed] == [d.seed for d in fresh]
    for a, b in zip(resumed, fresh, strict=True):
        assert np.array_equal(a.actions, b.actions) and np.array_equal(a.obs["object"],
                                                                       b.obs["object"])


def test_cli_generates_checks_and_lists(fake_kitchen, capsys):
    rc = data_cli.main(["--task", "kitchen/reach_b", "--source", "all", "--n", "2",
                        "--preset", "smoke", "--workers", "1", "--no-progress"])
    assert rc == 0
    gen = demo_path("smoke", "kitchen/reach_b", "generated")
    hum = demo_path("smoke", "kitchen/reach_b", "human")
    assert len(load_demos(gen)) == 2 and {d.source for d in load_demos(hum)} == {"human"}
    assert data_cli.main(["--check", str(hum), "--action-dim", "7"]) == 0
    assert "2 demos" in capsys.readouterr().out
    _corrupt(hum, lambda f: f["data/demo_0/actions"].__setitem__((0, 0), np.nan))
    assert data_cli.main(["--check", str(hum)]) == 1
    err = capsys.readouterr().err
    assert "demo 'demo_0'" in err and "NaN" in err
    assert data_cli.main(["--list", "--preset", "smoke"]) == 0
    assert "kinova/reach_a" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        data_cli.main(["--preset", "smoke"])


def test_recording_writes_rrd_and_picture(tmp_path):
    from icil_paper.viz.recording import record_episode

    demo = _demo(T=6, images=True)
    paths = record_episode(tmp_path / "rec" / "demo.rrd", demo.obs, demo.actions,
                           latents=np.zeros((6, 3)), title="demo", object_position=(0, 3))
    assert paths["png"].read_bytes()[:4] == b"\x89PNG"
    if paths["rrd"] is not None:
        assert paths["rrd"].stat().st_size > 0
    listed = [{k: v[t] for k, v in demo.obs.items()} for t in range(6)]
    only_png = record_episode(tmp_path / "b.rrd", listed, demo.actions, rrd=False)
    assert only_png["rrd"] is None and only_png["png"].exists()
    with pytest.raises(ValueError, match="steps"):
        record_episode(tmp_path / "c.rrd", demo.obs, demo.actions[:3])


def test_a_demonstration_set_is_locked_under_its_own_name(fake_kitchen, monkeypatch):
    """Generating set k locks set k's file, not the preset's base set: a process generating
    the base set never waits on, or races with, a writer of another set."""
    locked = []
    real = generate.data_set_lock
    monkeypatch.setattr(generate, "data_set_lock",
                        lambda path: locked.append(path) or real(path))
    seed = data_set_seed(get_preset("smoke").seed, 3)
    path = ensure_demos("smoke", TASK, "generated", n=1, workers=1, progress=False, seed=seed)
    assert locked == [path] == [demo_path("smoke", TASK, "generated", seed=seed)]
    assert path.name == "generated.set3.hdf5"
