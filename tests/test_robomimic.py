"""robomimic interoperability: robomimic's own loader reads our data sets with its defaults (when
robomimic is installed), and any robomimic-layout file loads as training data."""

from __future__ import annotations

import json
import warnings

import h5py
import numpy as np
import pytest

from icil_paper.data import (
    DatasetError,
    dataset_obs_keys,
    ensure_demos,
    load_dataset_file,
    load_demos,
)

TASK = "synthetic/task1"  # the simulator-free suite: generation takes milliseconds


def _robomimic():
    """robomimic's dataset and observation modules, or skip saying why."""
    try:
        import robomimic.utils.obs_utils as obs_utils
        from robomimic.utils.dataset import SequenceDataset
    except Exception as exc:  # noqa: BLE001 - any import failure skips with the reason
        pytest.skip(f"robomimic is not installed here ({type(exc).__name__}: {exc}); it is an "
                    "optional tool: `pip install robomimic==0.3.0 --no-deps` runs this test")
    return obs_utils, SequenceDataset


@pytest.fixture
def data_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    return tmp_path / "data"


@pytest.mark.parametrize("obs", ["state", "rgbd"])
def test_robomimic_sequence_dataset_reads_our_data_sets_with_its_defaults(data_dir, obs):
    obs_utils, SequenceDataset = _robomimic()
    path = ensure_demos("smoke", TASK, "generated", n=3, workers=1, progress=False, obs=obs)
    demos = load_demos(path)
    images = ["camera0_image"] if obs == "rgbd" else []
    depths = ["camera0_depth"] if obs == "rgbd" else []
    obs_utils.initialize_obs_utils_with_obs_specs({"obs": {
        "low_dim": ["proprio", "object"], "rgb": images, "depth": depths}})
    keys = ("proprio", "object", *images, *depths)
    dataset_keys = ("actions", "rewards", "dones")  # robomimic's config default
    for kwargs in ({}, {"hdf5_cache_mode": "all"},  # constructor defaults; training defaults
                   {"goal_mode": "last", "filter_by_attribute": "train"}):
        data = SequenceDataset(str(path), obs_keys=keys, dataset_keys=dataset_keys, **kwargs)
        assert len(data) == sum(len(d) for d in demos if d.name in data.demos) > 0
        first = demos[0]
        start = data._demo_id_to_start_indices[first.name]
        for t in (0, len(first) - 1):
            item = data[start + t]
            assert np.allclose(item["actions"][0], first.actions[t])
            assert np.allclose(item["obs"]["proprio"][0], first.obs["proprio"][t])
            after = (first.obs["proprio"][t + 1] if t + 1 < len(first)
                     else first.final_obs["proprio"])
            assert np.allclose(item["next_obs"]["proprio"][0], after)
            if images:
                assert item["obs"]["camera0_image"].shape == (1, 16, 16, 3)
                assert np.array_equal(item["obs"]["camera0_image"][0], first.obs["rgb"][t, 0])
                assert np.allclose(item["obs"]["camera0_depth"][0, ..., 0],
                                   first.obs["depth"][t, 0])
                processed = obs_utils.process_obs_dict({k: item["obs"][k][0] for k in keys})
                assert processed["camera0_image"].shape == (3, 16, 16)  # robomimic's encoders
                assert processed["camera0_depth"].shape == (1, 16, 16)
            if "goal_mode" in kwargs:
                assert np.allclose(item["goal_obs"]["proprio"], first.final_obs["proprio"])
        data.close_and_delete_hdf5_handle()
    with h5py.File(path) as f:
        env_meta = json.loads(f["data"].attrs["env_args"])  # as robomimic's file_utils reads it
        assert f[f"data/{demos[0].name}/states"].dtype == np.float64
    assert env_meta["type"] == 2 and env_meta["env_kwargs"]["obs"] == obs


def _robomimic_file(path, demo_keys, lengths=(6, 4), seed=0, action_dim=7):
    """A file as robosuite / robomimic tools write it: float64 low-dim keys, one key per camera."""
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "Lift", "type": 1, "env_kwargs": {}})
        for i, T in enumerate(lengths):
            g = data.create_group(f"demo_{i}")
            g.attrs["num_samples"] = T
            g.create_dataset("actions", data=rng.uniform(-1, 1, (T, action_dim)))
            for key, width in demo_keys.items():
                if key.endswith("_image"):
                    g.create_dataset(f"obs/{key}", data=rng.integers(0, 255, (T, 8, 8, 3),
                                                                     dtype=np.uint8))
                else:
                    g.create_dataset(f"obs/{key}", data=rng.normal(size=(T, width)))
    return path


def _obs(path, demo, key):
    with h5py.File(path) as f:
        return f[f"data/{demo}/obs/{key}"][()]


def test_default_key_mapping_falls_back_and_warns_about_dropped_keys(tmp_path):
    path = _robomimic_file(tmp_path / "lift.hdf5", {
        "robot0_eef_pos": 3, "robot0_eef_quat": 4, "robot0_joint_pos": 7, "cube_pos": 3,
        "cube_quat": 4, "agentview_image": 0})
    keys = dataset_obs_keys(path)
    assert keys.proprio == ("robot0_eef_pos", "robot0_eef_quat")  # gripper_qpos is absent
    assert keys.object == ("cube_pos", "cube_quat") and keys.rgb == ("agentview_image",)
    assert keys.dropped == ("robot0_joint_pos",)
    with pytest.warns(UserWarning, match=r"observation keys not used: robot0_joint_pos \(using "
                                         "proprio = robot0_eef_pos | robot0_eef_quat"):
        demos = load_dataset_file(path, action_dim=7)
    d = demos[1]
    assert d.obs["proprio"].shape == (4, 7) and d.obs["proprio"].dtype == np.float32
    expected = np.concatenate([_obs(path, "demo_1", "cube_pos"), _obs(path, "demo_1",
                                                                      "cube_quat")], axis=1)
    assert np.allclose(d.obs["object"], expected)
    assert d.obs["rgb"].shape == (4, 1, 8, 8, 3) and d.cameras == ("agentview",)
    assert d.task == "Lift" and d.source == "robomimic"

    # no robosuite end-effector keys: every robot key makes proprio, the rest object
    bare = _robomimic_file(tmp_path / "bare.hdf5", {"robot0_joint_pos": 7,
                                                    "robot0_joint_vel": 7, "drawer": 1})
    keys = dataset_obs_keys(bare)
    assert keys.proprio == ("robot0_joint_pos", "robot0_joint_vel") and keys.object == ("drawer",)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing dropped: no warning
        demos = load_dataset_file(bare)
    assert demos[0].obs["proprio"].shape == (6, 14) and demos[0].obs["object"].shape == (6, 1)


def test_obs_keys_choose_the_keys(tmp_path):
    path = _robomimic_file(tmp_path / "lift.hdf5", {
        "robot0_eef_pos": 3, "robot0_joint_pos": 7, "cube_pos": 3, "agentview_image": 0})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # chosen keys: what is left out is no surprise
        demos = load_dataset_file(path, obs_keys=["robot0_joint_pos", "cube_pos"])
    assert np.allclose(demos[0].obs["proprio"], _obs(path, "demo_0", "robot0_joint_pos"))
    assert np.allclose(demos[0].obs["object"], _obs(path, "demo_0", "cube_pos"))
    assert "rgb" not in demos[0].obs
    explicit = load_dataset_file(path, obs_keys={"proprio": ["robot0_eef_pos"],
                                                 "object": ["cube_pos", "robot0_joint_pos"]})
    assert explicit[0].obs["object"].shape == (6, 10)
    with pytest.raises(DatasetError, match=r"demo 'demo_0': missing key 'obs/cube_quat'.*"
                                           "agentview_image, cube_pos, robot0_eef_pos"):
        load_dataset_file(path, obs_keys=["cube_quat"])
    with pytest.raises(DatasetError, match="obs/agentview_image cannot go into object"):
        load_dataset_file(path, obs_keys={"object": ["agentview_image"]})
    with pytest.raises(DatasetError, match="action dimension 7 does not match the expected 6"):
        load_dataset_file(path, obs_keys=["cube_pos"], action_dim=6)


def test_foreign_demo_without_a_task_gets_the_file_name(tmp_path):
    path = _robomimic_file(tmp_path / "my_task.hdf5", {"robot0_eef_pos": 3, "object": 5})
    with h5py.File(path, "a") as f:
        del f["data"].attrs["env_args"]
    demos = load_dataset_file(path, limit=1)
    assert len(demos) == 1 and demos[0].task == "my_task"
    assert demos[0].obs["object"].shape == (6, 5)
