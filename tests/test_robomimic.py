"""robomimic interoperability: robomimic's own loader reads our data sets with its defaults, its
own BC training runs on them (rollouts off), and any robomimic-layout file trains our policies.

robomimic 0.3.0 is pinned in requirements-no-deps.txt (`make setup` installs it), so these tests
run in `make test` and CI; a missing robomimic fails them and names the fix."""

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
# robomimic imports torchvision 0.16.2 (requirements-no-deps.txt), whose C image decoders do not
# load against the CPU torch; robomimic uses none of them on low-dim data.
pytestmark = pytest.mark.filterwarnings("ignore:Failed to load image Python extension")


def _robomimic():
    """robomimic's dataset and observation modules (a failure that names the fix without it)."""
    try:
        import robomimic.utils.obs_utils as obs_utils
        from robomimic.utils.dataset import SequenceDataset
    except ImportError as exc:
        pytest.fail(f"robomimic does not import ({type(exc).__name__}: {exc}); it is pinned in "
                    "requirements-no-deps.txt: run `make setup`", pytrace=False)
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


# --------------------------------------------------------------------------- robomimic's training
def _bc_config(path, out_dir, **train):
    """robomimic's own BC config (its config factory) on our low-dim keys, rollouts off."""
    from robomimic.config import config_factory

    config = config_factory(algo_name="bc")
    with config.values_unlocked():
        config.train.data = str(path)
        config.train.output_dir = str(out_dir)
        config.train.seed = 0
        config.train.cuda = False
        for key, value in train.items():
            setattr(config.train, key, value)
        config.experiment.rollout.enabled = False  # its env factory cannot build our envs
        config.experiment.logging.log_tb = False
        config.experiment.logging.terminal_output_to_txt = False
        config.observation.modalities.obs.low_dim = ["proprio", "object"]
        config.observation.modalities.obs.rgb = []
    return config


def test_robomimic_bc_trains_on_our_data_set(data_dir, tmp_path):
    """robomimic's BC (default network and optimiser) trains on a data set we generated: its
    shape metadata comes from our file and its loss is finite and falls."""
    import torch
    from torch.utils.data import DataLoader

    obs_utils, _ = _robomimic()
    import robomimic.utils.file_utils as file_utils
    import robomimic.utils.train_utils as train_utils
    from robomimic.algo import algo_factory
    from robomimic.algo.bc import BC

    path = ensure_demos("smoke", TASK, "generated", n=6, workers=1, progress=False, obs="state")
    demos = load_demos(path)
    config = _bc_config(path, tmp_path / "robomimic", batch_size=16)
    torch.manual_seed(0)
    obs_utils.initialize_obs_utils_with_config(config)
    shape_meta = file_utils.get_shape_metadata_from_dataset(
        dataset_path=config.train.data, all_obs_keys=config.all_obs_keys)
    assert shape_meta["ac_dim"] == demos[0].actions.shape[1]
    assert shape_meta["all_shapes"]["proprio"] == [demos[0].obs["proprio"].shape[1]]
    model = algo_factory(config.algo_name, config, obs_key_shapes=shape_meta["all_shapes"],
                         ac_dim=shape_meta["ac_dim"], device=torch.device("cpu"))
    assert isinstance(model, BC)
    trainset, validset = train_utils.load_data_for_training(config, obs_keys=shape_meta["all_obs_keys"])
    assert validset is None and len(trainset) == sum(len(d) for d in demos)
    loader = DataLoader(trainset, batch_size=config.train.batch_size, shuffle=True,
                        drop_last=True, generator=torch.Generator().manual_seed(0))
    # robomimic's own epoch loop (what its train script calls), four epochs of 4 steps
    losses = [train_utils.run_epoch(model, loader, epoch=epoch, num_steps=4)["Loss"]
              for epoch in range(1, 5)]
    assert np.isfinite(losses).all(), losses
    assert losses[-1] < 0.8 * losses[0], losses


def test_robomimic_train_script_runs_on_our_data_set_without_rollouts(data_dir, tmp_path):
    """robomimic's train script end to end (env metadata, logger, checkpoint) with rollouts
    disabled, as the README says; the checkpoint's policy acts on our observations."""
    import torch

    _robomimic()
    import robomimic.utils.file_utils as file_utils
    from robomimic.scripts.train import train

    path = ensure_demos("smoke", TASK, "generated", n=4, workers=1, progress=False, obs="state")
    demo = load_demos(path)[0]
    config = _bc_config(path, tmp_path / "robomimic", batch_size=8, num_epochs=2)
    with config.values_unlocked():
        config.experiment.epoch_every_n_steps = 3
        config.experiment.save.every_n_epochs = None
        config.experiment.save.epochs = [2]
        config.algo.actor_layer_dims = (64, 64)
    config.lock()
    threads = torch.get_num_threads()
    try:
        train(config, device=torch.device("cpu"))
    finally:
        torch.set_num_threads(threads)  # its train() sets 2 threads for the whole process
    checkpoints = sorted((tmp_path / "robomimic").rglob("model_epoch_2.pth"))
    assert len(checkpoints) == 1
    policy, ckpt = file_utils.policy_from_checkpoint(ckpt_path=str(checkpoints[0]),
                                                     device=torch.device("cpu"))
    with h5py.File(path) as f:
        env_args = json.loads(f["data"].attrs["env_args"])
    assert ckpt["env_metadata"]["env_name"] == env_args["env_name"]  # our gymnasium id
    policy.start_episode()
    action = policy({k: demo.obs[k][0] for k in ("proprio", "object")})
    assert action.shape == demo.actions.shape[1:] and np.isfinite(action).all()


# --------------------------------------------------------------------------- robosuite files
ROBOSUITE_LIFT_KEYS = {
    # robomimic's Lift data sets (robosuite's observables, as dataset_states_to_obs keeps them)
    "object": 10, "robot0_eef_pos": 3, "robot0_eef_quat": 4, "robot0_eef_vel_ang": 3,
    "robot0_eef_vel_lin": 3, "robot0_gripper_qpos": 2, "robot0_gripper_qvel": 2,
    "robot0_joint_pos": 7, "robot0_joint_pos_cos": 7, "robot0_joint_pos_sin": 7,
    "robot0_joint_vel": 7, "agentview_image": 0, "robot0_eye_in_hand_image": 0,
}


def _robosuite_file(path, lengths=(14, 11, 12, 10), seed=0):
    """A Lift file laid out as robomimic's `dataset_states_to_obs` writes robosuite demos
    (obs and next_obs groups, float64 states, rewards, dones, the model xml, `total`, a
    robosuite `env_args`), split by robomimic's own `split_train_val_from_hdf5`."""
    from robomimic.scripts.split_train_val import split_train_val_from_hdf5

    rng = np.random.default_rng(seed)
    env_args = {"env_name": "Lift", "type": 1, "env_kwargs": {
        "has_renderer": False, "has_offscreen_renderer": True, "use_camera_obs": True,
        "robots": ["Panda"], "control_freq": 20, "camera_heights": 16, "camera_widths": 16,
        "controller_configs": {"type": "OSC_POSE", "control_delta": True}}}
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        for i, T in enumerate(lengths):
            g = data.create_group(f"demo_{i}")
            g.create_dataset("actions", data=rng.uniform(-1, 1, (T, 7)))
            g.create_dataset("states", data=rng.normal(size=(T, 32)))
            g.create_dataset("rewards", data=np.r_[np.zeros(T - 1), 1.0])
            g.create_dataset("dones", data=np.r_[np.zeros(T - 1, np.int64), 1])
            for key, width in ROBOSUITE_LIFT_KEYS.items():
                if key.endswith("_image"):
                    seq = rng.integers(0, 255, (T + 1, 16, 16, 3), dtype=np.uint8)
                    kwargs = {"compression": "gzip"}
                else:
                    seq = rng.normal(size=(T + 1, width))
                    kwargs = {}
                g.create_dataset(f"obs/{key}", data=seq[:-1], **kwargs)
                g.create_dataset(f"next_obs/{key}", data=seq[1:], **kwargs)
            g.attrs["model_file"] = "<mujoco model='base'></mujoco>"
            g.attrs["num_samples"] = T
        data.attrs["total"] = int(sum(lengths))
        data.attrs["env_args"] = json.dumps(env_args, indent=4)
    np.random.seed(seed)  # split_train_val_from_hdf5 shuffles with numpy's global generator
    split_train_val_from_hdf5(str(path), val_ratio=0.25)
    return path


def test_train_dataset_reads_a_robosuite_file_as_robomimic_writes_it(tmp_path):
    """`icil-paper train --dataset FILE` end to end on a robomimic-written robosuite file: our
    demos are what robomimic's own loader reads from it, the run trains, and the policy it
    stores acts on the file's observations with the file's demos as its prompt."""
    import hashlib

    from icil_paper.cli import main
    from icil_paper.results import ResultsStore
    from icil_paper.train import CONFIG_FILE, load_policy

    obs_utils, SequenceDataset = _robomimic()
    path = _robosuite_file(tmp_path / "lift_ph_low_dim.hdf5")
    with h5py.File(path) as f:
        assert sorted(f["mask"]) == ["train", "valid"] and len(f["mask/valid"]) == 1

    keys = dataset_obs_keys(path)
    assert keys.proprio == ("robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos")
    assert keys.object == ("object",)
    assert keys.rgb == ("agentview_image", "robot0_eye_in_hand_image")
    with pytest.warns(UserWarning, match="observation keys not used: robot0_eef_vel_ang"):
        demos = load_dataset_file(path, action_dim=7)
    assert [len(d) for d in demos] == [14, 11, 12, 10] and demos[0].task == "Lift"

    # robomimic's SequenceDataset on the same file gives the same steps
    obs_utils.initialize_obs_utils_with_obs_specs({"obs": {
        "low_dim": [*keys.proprio, *keys.object], "rgb": list(keys.rgb)}})
    ours = {d.name: d for d in demos}
    data = SequenceDataset(str(path), obs_keys=(*keys.proprio, *keys.object, *keys.rgb),
                           dataset_keys=("actions", "rewards", "dones"),
                           hdf5_cache_mode="all", filter_by_attribute="train")
    assert len(data.demos) == 3
    for name in data.demos:
        start, demo = data._demo_id_to_start_indices[name], ours[name]
        for t in range(len(demo)):
            item = data[start + t]
            proprio = np.concatenate([item["obs"][k][0] for k in keys.proprio])
            assert np.allclose(demo.obs["proprio"][t], proprio, atol=1e-6)
            assert np.allclose(demo.obs["object"][t], item["obs"]["object"][0], atol=1e-6)
            assert np.allclose(demo.actions[t], item["actions"][0], atol=1e-6)
            assert np.array_equal(demo.obs["rgb"][t, 1], item["obs"]["robot0_eye_in_hand_image"][0])
    data.close_and_delete_hdf5_handle()

    run = tmp_path / "run"
    with pytest.warns(UserWarning, match="observation keys not used"):
        code = main(["train", "--preset", "smoke", "--dataset", str(path), "--run-dir", str(run),
                     "--set", "train.steps=3", "--quiet"])
    assert code == 0
    config = json.loads((run / CONFIG_FILE).read_text())["spec"]
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    assert config["data"]["dataset_sha256"] == digest and config["data"]["tasks"] == ["Lift"]
    records = list(ResultsStore("smoke").root.rglob("*.json"))
    assert any(digest in r.read_text() for r in records)  # the train record names the file

    policy = load_policy(run)
    assert policy.obs_spec.lowdim_dim == 9 + 10 and policy.action_dim == 7
    policy.reset(prompt=demos[:2])
    query = demos[2]
    action = policy.select_action({k: v[0] for k, v in query.obs.items()})
    assert action.shape == (7,) and np.isfinite(action).all()
