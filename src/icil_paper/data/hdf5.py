"""Demonstrations in robomimic's HDF5 layout: writer, loader and validation.

Layout written (robomimic's, the one robosuite, RoboCasa and MimicGen data sets use)::

    data                      attrs: total (steps), env_args (JSON), task, source, obs_kind,
    |                                base_seed, action_dim, format
    +-- demo_0                attrs: num_samples, task, source, instruction, seed, ep_meta (JSON)
    |   +-- actions           (T, 7) float32
    |   +-- obs/proprio       (T, P) float32
    |   +-- obs/object        (T, O) float32
    |   +-- obs/rgb           (T, n_cams, H, W, 3) uint8    (image data sets only)
    |   +-- obs/depth         (T, n_cams, H, W) float32     (rgbd data sets only)
    |   +-- states            (T, S) float32  simulator state before each action (optional)
    |   +-- rewards, dones    (T,)
    +-- demo_1 ...
    mask/train, mask/valid    demo names (bytes), robomimic's filter keys

Files written by robosuite / robomimic tools (RoboCasa, MimicGen) load too; their observation
keys are mapped onto the project's (`ROBOMIMIC_KEY_MAP`):

    proprio = robot0_eef_pos (3) | robot0_eef_quat (4, x y z w) | robot0_gripper_qpos (2)
    object  = object                    (zero columns when the file has none)
    rgb     = every `<camera>_image`    stacked in sorted camera order
    depth   = every `<camera>_depth`    same order, trailing channel dropped

and a demo's task, instruction and seed come from its attrs, else from `env_args["env_name"]`,
RoboCasa's `ep_meta["lang"]`, and -1 (unknown). `load_demos` validates every demo and raises
`DatasetError` naming the file, the demo and the problem.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "icil_paper/1"
ROBOMIMIC_PROPRIO_KEYS = ("robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos")
ROBOMIMIC_KEY_MAP = {
    "proprio": "robot0_eef_pos | robot0_eef_quat | robot0_gripper_qpos (concatenated)",
    "object": "object",
    "rgb": "<camera>_image for every camera, sorted by name",
    "depth": "<camera>_depth for every camera, sorted by name",
}
"""How observation keys of robosuite / robomimic files map onto the project's keys."""


class DatasetError(ValueError):
    """A demonstration file that cannot be used; the message names file, demo and problem."""


@dataclass
class Demo:
    """One demonstration: T steps of observations and the actions taken from them.

    `obs[key][t]` is the observation before `actions[t]`. Keys: "proprio" (T, P), "object"
    (T, O), optionally "rgb" (T, n_cams, H, W, 3) uint8 and "depth" (T, n_cams, H, W).
    """

    actions: np.ndarray
    """(T, A) float32 actions."""
    obs: dict[str, np.ndarray]
    """Observation arrays, each (T, ...)."""
    task: str
    """Task name, e.g. `maniskill/pick_cube` (for foreign files: their env name)."""
    source: str
    """`generated`, `human`, or where a foreign file came from."""
    instruction: str = ""
    """Language instruction of the task."""
    seed: int = -1
    """Environment seed of the episode (-1 when unknown, e.g. in files of other tools)."""
    name: str = ""
    """Key of the demo in its file (`demo_N`)."""
    states: np.ndarray | None = None
    """(T, S) simulator states before each action, when recorded."""
    rewards: np.ndarray | None = None
    """(T,) rewards, when recorded."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Other per-demo attributes of the file."""

    def __len__(self) -> int:
        return int(self.actions.shape[0])


# ------------------------------------------------------------------------------------- writing
def _demo_index(name: str) -> int:
    match = re.fullmatch(r"demo_(\d+)", name)
    return int(match.group(1)) if match else 1 << 62


def sorted_demo_names(names: Iterable[str]) -> list[str]:
    """`demo_N` names in numeric order (demo_2 before demo_10); others after them."""
    return sorted(names, key=lambda n: (_demo_index(n), n))


def _write_demo(group: Any, demo: Demo) -> None:
    T = len(demo)
    group.create_dataset("actions", data=np.asarray(demo.actions, np.float32))
    obs = group.create_group("obs")
    for key, value in demo.obs.items():
        value = np.asarray(value)
        if value.dtype == np.float64:
            value = value.astype(np.float32)
        kwargs = {"compression": "gzip", "compression_opts": 4} if value.ndim >= 4 else {}
        obs.create_dataset(key, data=value, **kwargs)
    if demo.states is not None:
        group.create_dataset("states", data=np.asarray(demo.states, np.float32))
    rewards = demo.rewards if demo.rewards is not None else np.zeros(T, np.float32)
    group.create_dataset("rewards", data=np.asarray(rewards, np.float32))
    dones = np.zeros(T, np.int64)
    dones[-1] = 1
    group.create_dataset("dones", data=dones)
    group.attrs["num_samples"] = T
    group.attrs["task"] = demo.task
    group.attrs["source"] = demo.source
    group.attrs["instruction"] = demo.instruction
    group.attrs["seed"] = int(demo.seed)
    group.attrs["ep_meta"] = json.dumps({"lang": demo.instruction})  # RoboCasa's key
    for key, value in demo.meta.items():
        group.attrs[key] = value


def write_demos(path: str | Path, demos: Sequence[Demo], file_attrs: dict[str, Any] | None = None,
                valid_fraction: float = 0.1, split_seed: int = 0,
                names: Sequence[str] | None = None) -> Path:
    """Write demos to `path` atomically (temporary file, then rename); return the path.

    `names` default to demo_0, demo_1, ...; `file_attrs` go onto the `data` group (with
    `env_args` JSON-encoded). The train/valid masks come from `splits.train_valid_split`.
    """
    from icil_paper.data.splits import train_valid_split

    path = Path(path)
    names = list(names) if names is not None else [f"demo_{i}" for i in range(len(demos))]
    if len(names) != len(demos):
        raise ValueError(f"{len(names)} names for {len(demos)} demos")
    with _atomic_h5(path) as f:
        data = f.create_group("data")
        for name, demo in zip(names, demos, strict=True):
            _write_demo(data.create_group(name), demo)
        _finish_file(f, file_attrs or {}, valid_fraction, split_seed, train_valid_split)
    return path


def _finish_file(f: Any, file_attrs: dict[str, Any], valid_fraction: float, split_seed: int,
                 train_valid_split: Any) -> None:
    data = f["data"]
    names = sorted_demo_names(data.keys())
    data.attrs["total"] = int(sum(int(data[n]["actions"].shape[0]) for n in names))
    data.attrs["format"] = FORMAT
    for key, value in file_attrs.items():
        data.attrs[key] = json.dumps(value) if key == "env_args" else value
    masks = train_valid_split(names, valid_fraction=valid_fraction, seed=split_seed)
    group = f.require_group("mask")
    for key, members in masks.items():
        group.create_dataset(key, data=np.array(members, dtype="S"))


class _atomic_h5:
    """Context manager: an h5py File on a temporary path, renamed onto `path` on success."""

    def __init__(self, path: Path):
        self.path = Path(path)

    def __enter__(self):
        import h5py

        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, self.tmp = tempfile.mkstemp(dir=self.path.parent, prefix=f".{self.path.name}.",
                                        suffix=".tmp")
        os.close(fd)
        self.file = h5py.File(self.tmp, "w")
        return self.file

    def __exit__(self, exc_type, exc, tb):
        try:
            self.file.close()
            if exc_type is None:
                with open(self.tmp, "rb+") as fh:
                    os.fsync(fh.fileno())
                os.replace(self.tmp, self.path)
        finally:
            if os.path.exists(self.tmp):
                os.unlink(self.tmp)
        return False


def merge_demo_files(path: str | Path, parts: Sequence[tuple[str | Path, str, str]],
                     file_attrs: dict[str, Any], valid_fraction: float = 0.1,
                     split_seed: int = 0) -> Path:
    """Atomically write `path` from demos copied out of other files.

    `parts` is a list of (file, demo name in that file, demo name in the output); the copy
    keeps datasets and attrs bit for bit. `path` itself may be one of the inputs.
    """
    import h5py

    from icil_paper.data.splits import train_valid_split

    path = Path(path)
    with _atomic_h5(path) as out:
        data = out.create_group("data")
        opened: dict[str, Any] = {}
        try:
            for src, src_name, dst_name in parts:
                key = str(src)
                if key not in opened:
                    opened[key] = h5py.File(key, "r")
                opened[key].copy(opened[key]["data"][src_name], data, name=dst_name)
        finally:
            for f in opened.values():
                f.close()
        _finish_file(out, file_attrs, valid_fraction, split_seed, train_valid_split)
    return path


# ------------------------------------------------------------------------------------- reading
def _err(path: Path, demo: str | None, problem: str) -> DatasetError:
    where = f"{path}: demo {demo!r}: " if demo else f"{path}: "
    return DatasetError(where + problem)


def _attr(attrs: Any, key: str, default: Any = None) -> Any:
    if key not in attrs:
        return default
    value = attrs[key]
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, np.generic):
        value = value.item()
    return value


def file_info(path: str | Path) -> dict[str, Any]:
    """The `data` group's attributes and demo names of a file, without loading arrays."""
    import h5py

    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            if "data" not in f:
                raise _err(path, None, "no 'data' group (not a robomimic-layout file)")
            attrs = {k: _attr(f["data"].attrs, k) for k in f["data"].attrs}
            names = sorted_demo_names(k for k in f["data"].keys() if k.startswith("demo"))
    except OSError as exc:
        raise _err(path, None, f"not a readable HDF5 file ({exc})") from None
    if "env_args" in attrs and isinstance(attrs["env_args"], str):
        try:
            attrs["env_args"] = json.loads(attrs["env_args"])
        except json.JSONDecodeError:
            pass
    attrs["demos"] = names
    return attrs


def _finite(path: Path, name: str, key: str, value: np.ndarray) -> None:
    if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
        bad = np.argwhere(~np.isfinite(value))[0]
        raise _err(path, name, f"{key} has NaN or infinite values (first at index {tuple(bad)})")


def _read_obs(path: Path, name: str, group: Any, T: int) -> dict[str, np.ndarray]:
    if "obs" not in group:
        raise _err(path, name, "missing key 'obs'")
    raw = group["obs"]
    obs: dict[str, np.ndarray] = {}
    if "proprio" in raw:
        obs["proprio"] = raw["proprio"][()]
    elif "robot0_eef_pos" in raw:
        parts = [raw[k][()].reshape(T, -1) if k in raw and raw[k].shape[0] == T else None
                 for k in ROBOMIMIC_PROPRIO_KEYS]
        missing = [k for k, p in zip(ROBOMIMIC_PROPRIO_KEYS, parts, strict=True) if p is None]
        if missing:
            raise _err(path, name, f"robomimic observation keys {missing} are missing or not "
                                   f"{T} steps long (needed for 'proprio')")
        obs["proprio"] = np.concatenate(parts, axis=1)
    else:
        raise _err(path, name, "missing key 'obs/proprio' (and no robomimic 'robot0_eef_pos' "
                               f"to build it from); obs keys: {sorted(raw.keys())}")
    obs["object"] = raw["object"][()] if "object" in raw else np.zeros((T, 0), np.float32)
    if "rgb" in raw:
        obs["rgb"] = raw["rgb"][()]
    else:
        cams = sorted(k for k in raw if k.endswith("_image"))
        if cams:
            obs["rgb"] = np.stack([raw[k][()] for k in cams], axis=1)
    if "depth" in raw:
        obs["depth"] = raw["depth"][()]
    else:
        cams = sorted(k for k in raw if k.endswith("_depth"))
        if cams:
            depth = [raw[k][()] for k in cams]
            depth = [d[..., 0] if d.ndim == 4 else d for d in depth]
            obs["depth"] = np.stack(depth, axis=1)
    return obs


def _check_obs(path: Path, name: str, obs: dict[str, np.ndarray], T: int) -> None:
    for key, value in obs.items():
        if value.shape[0] != T:
            raise _err(path, name, f"obs/{key} has {value.shape[0]} steps but actions have {T}")
    for key in ("proprio", "object"):
        if obs[key].ndim != 2:
            raise _err(path, name, f"obs/{key} must be 2-D (T, dim), got shape {obs[key].shape}")
    if "rgb" in obs:
        rgb = obs["rgb"]
        if rgb.ndim != 5 or rgb.shape[-1] != 3:
            raise _err(path, name, f"obs/rgb must be (T, n_cams, H, W, 3), got {rgb.shape}")
        if rgb.dtype != np.uint8:
            raise _err(path, name, f"obs/rgb must be uint8, got {rgb.dtype}")
    if "depth" in obs:
        depth = obs["depth"]
        if depth.ndim != 4:
            raise _err(path, name, f"obs/depth must be (T, n_cams, H, W), got {depth.shape}")
        if "rgb" in obs and depth.shape[:4] != obs["rgb"].shape[:4]:
            raise _err(path, name, f"obs/depth {depth.shape} does not match obs/rgb "
                                   f"{obs['rgb'].shape}")
    for key, value in obs.items():
        _finite(path, name, f"obs/{key}", value)


def load_demos(path: str | Path, action_dim: int | None = None, limit: int | None = None,
               images: bool = True) -> list[Demo]:
    """Load and validate the demos of a robomimic-layout HDF5 file (ours or robomimic's).

    Args:
        path: the file.
        action_dim: expected action width; a mismatch raises DatasetError.
        limit: load only the first `limit` demos (in numeric order).
        images: load `rgb` / `depth` arrays (False skips them, for state-only training).

    Raises DatasetError naming the file, the demo and the problem: missing keys, wrong shapes,
    action width mismatch, steps that disagree between keys, NaN or infinite values, and
    observation widths that differ between the demos of one file.
    """
    import h5py

    path = Path(path)
    if not path.exists():
        raise _err(path, None, "file not found")
    info = file_info(path)
    names = info["demos"][:limit] if limit is not None else info["demos"]
    if not names:
        raise _err(path, None, "no demos under 'data' (expected groups named demo_N)")
    env_args = info.get("env_args") if isinstance(info.get("env_args"), dict) else {}
    file_task = info.get("task") or env_args.get("env_name") or ""
    file_source = info.get("source") or "robomimic"
    demos: list[Demo] = []
    widths: tuple[int, int] | None = None
    with h5py.File(path, "r") as f:
        for name in names:
            group = f["data"][name]
            if "actions" not in group:
                raise _err(path, name, "missing key 'actions'")
            actions = group["actions"][()]
            if actions.ndim != 2 or actions.shape[0] == 0:
                raise _err(path, name, f"actions must be (T, A) with T > 0, got {actions.shape}")
            T, A = actions.shape
            if action_dim is not None and A != action_dim:
                raise _err(path, name, f"action dimension {A} does not match the expected "
                                       f"{action_dim}")
            _finite(path, name, "actions", actions)
            obs = _read_obs(path, name, group, T)
            if not images:
                obs.pop("rgb", None)
                obs.pop("depth", None)
            _check_obs(path, name, obs, T)
            dims = (obs["proprio"].shape[1], obs["object"].shape[1])
            if widths is None:
                widths = dims
            elif dims != widths:
                raise _err(path, name, f"(proprio, object) widths {dims} differ from the "
                                       f"file's first demo {widths}")
            states = group["states"][()] if "states" in group else None
            if states is not None and states.shape[0] != T:
                raise _err(path, name, f"states have {states.shape[0]} steps but actions "
                                       f"have {T}")
            rewards = group["rewards"][()] if "rewards" in group else None
            attrs = group.attrs
            ep_meta = _attr(attrs, "ep_meta")
            try:
                lang = json.loads(ep_meta).get("lang", "") if ep_meta else ""
            except (json.JSONDecodeError, AttributeError):
                lang = ""
            known = {"num_samples", "task", "source", "instruction", "seed", "ep_meta"}
            demos.append(Demo(
                actions=actions.astype(np.float32),
                obs={k: (v.astype(np.float32) if v.dtype.kind == "f" else v)
                     for k, v in obs.items()},
                task=str(_attr(attrs, "task", file_task)),
                source=str(_attr(attrs, "source", file_source)),
                instruction=str(_attr(attrs, "instruction", lang) or lang),
                seed=int(_attr(attrs, "seed", -1)),
                name=name,
                states=None if states is None else states.astype(np.float32),
                rewards=None if rewards is None else rewards.astype(np.float32),
                meta={k: _attr(attrs, k) for k in attrs if k not in known},
            ))
    return demos


def read_masks(path: str | Path) -> dict[str, list[str]]:
    """robomimic's filter keys of a file (`mask/train`, `mask/valid`, ...) as lists of names."""
    import h5py

    with h5py.File(path, "r") as f:
        if "mask" not in f:
            return {}
        return {k: [n.decode() if isinstance(n, bytes) else str(n) for n in f["mask"][k][()]]
                for k in f["mask"]}
