"""The LeRobot exporter, run in its own environment (`make lerobot-setup`: Python 3.12 with
lerobot), and its output read back by LeRobot's own `LeRobotDataset`."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from icil_paper.data.hdf5 import Demo, write_demos
from icil_paper.setup.provenance import REPO_ROOT

LEROBOT_PYTHON = Path(os.environ.get("ICIL_LEROBOT_PYTHON", "").strip()
                      or REPO_ROOT / ".venv-lerobot" / "bin" / "python")

pytestmark = pytest.mark.skipif(
    not LEROBOT_PYTHON.exists(),
    reason=f"no LeRobot environment at {LEROBOT_PYTHON} (`make lerobot-setup` makes one; "
           "lerobot needs Python >= 3.12, apart from the main environment)")

READ_BACK = """
import json, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
ds = LeRobotDataset(sys.argv[1], root=sys.argv[2])
first = ds[0]
last = ds[len(ds) - 1]
print(json.dumps({
    "frames": len(ds), "episodes": ds.num_episodes, "fps": ds.fps,
    "robot_type": ds.meta.robot_type, "task": first["task"],
    "action0": first["action"].tolist(), "state0": first["observation.state"].tolist(),
    "object0": first["observation.environment_state"].tolist(),
    "image_keys": sorted(k for k in first if k.startswith("observation.images.")),
    "image_shape": [list(first[k].shape) for k in sorted(first)
                    if k.startswith("observation.images.")][:1],
    "last_episode": int(last["episode_index"]), "last_done": bool(last["next.done"]),
}))
"""


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT / "src"), "HF_HUB_OFFLINE": "1"}
    return subprocess.run([str(LEROBOT_PYTHON), *args], cwd=cwd, env=env, text=True,
                          capture_output=True, timeout=300)


def _data_set(path: Path, image: bool, control_freq: int | None = 20) -> Path:
    """Three demos of 6-8 steps written by the project's own writer (two cameras with
    depth when `image`)."""
    demos = []
    for i in range(3):
        rng = np.random.default_rng(i)
        T = 6 + i
        obs = {"proprio": rng.normal(size=(T, 9)).astype(np.float32),
               "object": rng.normal(size=(T, 6)).astype(np.float32)}
        if image:
            obs["rgb"] = rng.integers(0, 255, (T, 2, 16, 16, 3), dtype=np.uint8)
            obs["depth"] = rng.random((T, 2, 16, 16)).astype(np.float32)
        demos.append(Demo(actions=rng.uniform(-1, 1, (T, 7)).astype(np.float32), obs=obs,
                          task="kitchen/open_drawer", source="generated",
                          instruction="open the drawer", seed=i,
                          rewards=np.zeros(T, np.float32),
                          cameras=("agentview", "wrist") if image else ()))
    attrs = {"task": "kitchen/open_drawer"}
    if control_freq:
        attrs["control_freq"] = control_freq
    return write_demos(path, demos, file_attrs=attrs)


@pytest.mark.parametrize("image", [False, True])
def test_an_exported_data_set_reads_back_in_lerobot(tmp_path, image):
    source = _data_set(tmp_path / "demos.hdf5", image)
    out = tmp_path / "exported"
    done = _run("-m", "icil_paper.interop.lerobot_export", str(source), str(out), cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "LeRobotDataset v3.0" in done.stdout
    if image:
        assert "left out of the export" in done.stderr and "_depth" in done.stderr
    read = _run("-c", READ_BACK, f"icil_paper/{out.name}", str(out), cwd=tmp_path)
    assert read.returncode == 0, read.stderr[-2000:]
    got = json.loads(read.stdout.strip().splitlines()[-1])
    with h5py.File(source) as f:
        demo = f["data/demo_0"]
        lengths = [f[f"data/{n}/actions"].shape[0] for n in f["data"]]
        assert got["frames"] == sum(lengths) and got["episodes"] == len(lengths) == 3
        assert got["fps"] == 20 and got["task"] == demo.attrs["instruction"]
        np.testing.assert_allclose(got["action0"], demo["actions"][0], rtol=1e-6)
        np.testing.assert_allclose(got["state0"], demo["obs/proprio"][0], rtol=1e-6)
        np.testing.assert_allclose(got["object0"], demo["obs/object"][0], rtol=1e-6)
        cameras = sorted(k[:-len("_image")] for k in demo["obs"] if k.endswith("_image"))
    assert got["image_keys"] == [f"observation.images.{c}" for c in cameras]
    assert bool(cameras) == image
    if image:
        assert got["image_shape"] == [[3, 16, 16]]  # LeRobot returns channels first
    assert got["last_episode"] == 2 and got["last_done"] and got["robot_type"] == "panda"


def test_refusals_are_one_line_and_touch_nothing(tmp_path):
    source = _data_set(tmp_path / "demos.hdf5", image=False)
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "keep.txt").write_text("mine")
    done = _run("-m", "icil_paper.interop.lerobot_export", str(source), str(taken), cwd=tmp_path)
    assert done.returncode == 2 and "exists: choose a new folder" in done.stderr
    assert (taken / "keep.txt").read_text() == "mine"

    no_rate = _data_set(tmp_path / "no_rate.hdf5", image=False, control_freq=None)
    done = _run("-m", "icil_paper.interop.lerobot_export", str(no_rate), str(tmp_path / "new"),
                cwd=tmp_path)
    assert done.returncode == 2 and "give one with --fps" in done.stderr
    assert not (tmp_path / "new").exists() and not (tmp_path / "new.partial").exists()
