"""Export a demonstration data set (robomimic HDF5, as `icil-paper demos` writes it, or any
robomimic-layout file) to a LeRobotDataset (format v3.0), through LeRobot's own writer.

LeRobot 0.6 needs Python >= 3.12 and numpy >= 2, which the main environment cannot have, so
this module runs in a separate environment and imports nothing else of `icil_paper`:

    make lerobot-setup       # .venv-lerobot: Python 3.12 with lerobot[dataset] and h5py
    make lerobot-export FILE=data/small/kitchen/open_drawer/generated.hdf5 OUT=lerobot/open_drawer
    # or: PYTHONPATH=src .venv-lerobot/bin/python -m icil_paper.interop.lerobot_export FILE OUT

The result loads with `LeRobotDataset(repo_id, root=OUT)`. Per frame: `actions` -> `action`,
`rewards`/`dones` -> `next.reward`/`next.done`, `obs/proprio` (else every other low-dimensional
key) -> `observation.state`, `obs/object` -> `observation.environment_state`,
`obs/<camera>_image` -> `observation.images.<camera>`; other keys are left out with a warning.
The data set is built in `OUT.partial` and renamed at the end.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

STATE_KEY = "proprio"
"""The observation key that is the robot's state in this project's files."""
OBJECT_KEY = "object"
"""The observation key that holds object state (LeRobot's `observation.environment_state`)."""
ROBOT_TYPES = {"kitchen": "panda", "maniskill": "panda", "kinova": "kinova3", "synthetic": None}
"""LeRobot's `robot_type` by this project's task suite."""


class ExportError(ValueError):
    """A file that cannot be exported (not robomimic, no actions, no fps), or a taken OUT."""


def _demo_names(data: Any) -> list[str]:
    names = [k for k in data.keys() if k.startswith("demo_")]
    if not names:
        raise ExportError("no demos: a robomimic file holds groups data/demo_<i>")
    return sorted(names, key=lambda n: int(n.split("_", 1)[1]) if n[5:].isdigit() else n)


def plan_features(demo: Any) -> tuple[dict[str, Any], dict, list]:
    """(LeRobot features, {feature: [obs keys]}, keys left out) from one demo group."""
    if "actions" not in demo:
        raise ExportError(f"demo {demo.name}: no 'actions' dataset")
    obs = demo["obs"] if "obs" in demo else {}
    low_dim = sorted(k for k in obs if obs[k].ndim == 2 and obs[k].dtype != np.uint8)
    images = sorted(k for k in obs if k.endswith("_image") and obs[k].ndim == 4)
    state_keys = [STATE_KEY] if STATE_KEY in low_dim else [k for k in low_dim if k != OBJECT_KEY]
    sources = {"observation.state": state_keys}
    if OBJECT_KEY in low_dim:
        sources["observation.environment_state"] = [OBJECT_KEY]
    features: dict[str, Any] = {}
    for feature, keys in sources.items():
        if not keys:
            continue
        names = [f"{k}_{i}" for k in keys for i in range(obs[k].shape[1])]
        features[feature] = {"dtype": "float32", "shape": (len(names),), "names": names}
    for key in images:
        features[f"observation.images.{key[:-len('_image')]}"] = {
            "dtype": "image", "shape": tuple(obs[key].shape[1:]),
            "names": ["height", "width", "channel"]}
        sources[f"observation.images.{key[:-len('_image')]}"] = [key]
    action_dim = demo["actions"].shape[1]
    features["action"] = {"dtype": "float32", "shape": (action_dim,),
                          "names": [f"a{i}" for i in range(action_dim)]}
    if "rewards" in demo:
        features["next.reward"] = {"dtype": "float32", "shape": (1,), "names": None}
    if "dones" in demo:
        features["next.done"] = {"dtype": "bool", "shape": (1,), "names": None}
    used = {k for keys in sources.values() for k in keys}
    left_out = sorted(f"obs/{k}" for k in obs if k not in used)
    sources = {f: keys for f, keys in sources.items() if keys}
    return features, sources, left_out


def _task_text(demo: Any, file_attrs: dict[str, Any], fallback: str | None) -> str:
    for value in (demo.attrs.get("instruction"), file_attrs.get("task"), fallback):
        if value:
            return value.decode() if isinstance(value, bytes) else str(value)
    raise ExportError(f"demo {demo.name}: no instruction and the file names no task; "
                      "give one with --task")


def _robot_type(file_attrs: dict[str, Any]) -> str | None:
    task = str(file_attrs.get("task", ""))
    return ROBOT_TYPES.get(task.split("/", 1)[0]) if "/" in task else None


def export(path: str | Path, out: str | Path, repo_id: str | None = None,
           fps: int | None = None, task: str | None = None, videos: bool = False) -> Path:
    """Write the robomimic file `path` as a LeRobotDataset in the folder `out`; returns it."""
    import h5py

    path, out = Path(path), Path(out)
    if out.exists():
        raise ExportError(f"{out} exists: choose a new folder (a data set is never "
                          "written over)")
    try:
        f = h5py.File(path, "r")
    except (OSError, FileNotFoundError) as exc:
        raise ExportError(f"{path}: not a readable HDF5 file ({exc})") from None
    partial = out.with_name(out.name + ".partial")
    shutil.rmtree(partial, ignore_errors=True)
    try:
        with f:
            _write(f, path, partial, repo_id or f"icil_paper/{out.name}", fps, task, videos)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
    partial.rename(out)
    return out


def _write(f: Any, path: Path, partial: Path, repo_id: str, fps: int | None,
           task: str | None, videos: bool) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    if "data" not in f:
        raise ExportError(f"{path}: no 'data' group (not a robomimic file)")
    data = f["data"]
    file_attrs = {k: (v.decode() if isinstance(v, bytes) else v)
                  for k, v in data.attrs.items()}
    fps = fps or file_attrs.get("control_freq")
    if not fps:
        raise ExportError(f"{path}: the file stores no control rate "
                          "(data.attrs['control_freq']); give one with --fps")
    names = _demo_names(data)
    features, sources, left_out = plan_features(data[names[0]])
    if left_out:
        warnings.warn(f"{path}: left out of the export: {', '.join(left_out)}",
                      stacklevel=2)
    dataset = LeRobotDataset.create(
        repo_id=repo_id, fps=int(fps), features=features,
        root=partial, robot_type=_robot_type(file_attrs), use_videos=videos)
    for name in names:
        demo = data[name]
        if demo["actions"].shape[1:] != tuple(features["action"]["shape"]):
            raise ExportError(f"{path}: demo {name} has actions shaped "
                              f"{demo['actions'].shape[1:]}, the first demo "
                              f"{features['action']['shape']}")
        columns = {feature: np.concatenate([demo["obs"][k][()] for k in keys], axis=1)
                   for feature, keys in sources.items()}
        columns["action"] = demo["actions"][()]
        if "next.reward" in features:
            columns["next.reward"] = demo["rewards"][()].reshape(-1, 1)
        if "next.done" in features:
            columns["next.done"] = demo["dones"][()].reshape(-1, 1).astype(bool)
        text = _task_text(demo, file_attrs, task)
        for t in range(len(columns["action"])):
            frame = {feature: (values[t] if features[feature]["dtype"] in ("image", "bool")
                               else values[t].astype(np.float32))
                     for feature, values in columns.items()}
            dataset.add_frame({**frame, "task": text})
        dataset.save_episode()
    dataset.finalize()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icil_paper.interop.lerobot_export",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("file", help="a robomimic-layout HDF5 file")
    parser.add_argument("out", help="the new data set's folder (must not exist)")
    parser.add_argument("--repo-id", default=None,
                        help="LeRobot's repo id (default: icil_paper/<OUT's name>)")
    parser.add_argument("--fps", type=int, default=None,
                        help="frames per second, for a file that stores no control rate")
    parser.add_argument("--task", default=None,
                        help="the task text, for demos without an instruction")
    parser.add_argument("--videos", action="store_true",
                        help="store cameras as MP4 videos (LeRobot's encoder) instead of images")
    args = parser.parse_args(argv)
    try:
        out = export(args.file, args.out, args.repo_id, args.fps, args.task, args.videos)
    except ExportError as exc:
        print(f"lerobot_export: error: {exc}", file=sys.stderr)
        return 2
    info = json.loads((out / "meta" / "info.json").read_text())
    print(f"wrote {out}: {info['total_episodes']} episodes, {info['total_frames']} frames "
          f"at {info['fps']} fps (LeRobotDataset {info['codebase_version']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
