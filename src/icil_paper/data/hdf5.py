"""Demonstrations in robomimic's HDF5 layout: writer, loader, validation and integrity checks.

    demos = load_demos(path)                  # [Demo], validated; DatasetError names problems

Layout written (robomimic's, also robosuite's, RoboCasa's and MimicGen's, so robomimic's
`SequenceDataset` reads it with its default arguments)::

    data                      attrs: total, env_args (JSON), task, source, obs_kind,
    |                                base_seed, action_dim, control_freq, depth_units, format
    +-- demo_0                attrs: num_samples, task, source, instruction, seed, ep_meta
    |   +-- actions           (T, 7) float32
    |   +-- obs/proprio       (T, P) float32
    |   +-- obs/object        (T, O) float32
    |   +-- obs/<cam>_image   (T, H, W, 3) uint8          one per camera (image data sets)
    |   +-- obs/<cam>_depth   (T, H, W, 1) float32 metres  one per camera (rgbd data sets)
    |   +-- next_obs/...      the same keys: the observation after each action
    |   +-- states            (T, S) float64, optional; rewards, dones (T,)
    +-- demo_1 ...
    mask/train, mask/valid    demo names, robomimic's filter keys

Every dataset carries a Fletcher-32 checksum. Files of layout version 1 (stacked
`obs/rgb`, `obs/depth`) still load; other tools' keys are mapped by `data.obs_keys`.
"""

from __future__ import annotations

import contextlib
import json
import re
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper.data import memo
from icil_paper.data.obs_keys import ObsKeyMap, camera_of, map_obs_keys
from icil_paper.data.splits import train_valid_split
from icil_paper.fileio import atomic_path

FORMAT = "icil_paper/2"
"""Layout version written into `data.attrs["format"]` (version 1: stacked images, no next_obs)."""
DEPTH_UNITS = "m"
H5_ERRORS = (OSError, RuntimeError, KeyError)
"""What h5py raises on a damaged file (bad checksum, truncated file, broken links)."""


class DatasetError(ValueError):
    """A demonstration file that cannot be used; the message names file, demo and problem."""


@dataclass
class Demo:
    """One demonstration: `obs[key][t]` is the observation before `actions[t]`.

    Keys: "proprio" (T, P), "object" (T, O), optionally "rgb" (T, n_cams, H, W, 3) uint8 and
    "depth" (T, n_cams, H, W) metres.
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
    """(T, S) float64 simulator states before each action, when recorded."""
    rewards: np.ndarray | None = None
    """(T,) rewards, when recorded."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Other per-demo attributes of the file."""
    final_obs: dict[str, np.ndarray] | None = None
    """The observation after the last action (keys of `obs`, no time axis), when known."""
    cameras: tuple[str, ...] = ()
    """Names of the cameras along the camera axis of `obs["rgb"]` / `obs["depth"]`."""

    def __len__(self) -> int:
        return int(self.actions.shape[0])


# ------------------------------------------------------------------------------------- writing
def _demo_index(name: str) -> int:
    match = re.fullmatch(r"demo_(\d+)", name)
    return int(match.group(1)) if match else 1 << 62


def sorted_demo_names(names: Iterable[str]) -> list[str]:
    """`demo_N` names in numeric order (demo_2 before demo_10); others after them."""
    return sorted(names, key=lambda n: (_demo_index(n), n))


def _dataset(group: Any, name: str, data: np.ndarray, compress: bool = False) -> None:
    """A dataset with a Fletcher-32 checksum (gzip too for images)."""
    kwargs: dict[str, Any] = {"fletcher32": data.size > 0}
    if compress and data.size > 0:
        kwargs.update(compression="gzip", compression_opts=4)
    group.create_dataset(name, data=data, **kwargs)


def camera_names(demo: Any, n_cams: int) -> tuple[str, ...]:
    """The demo's camera names, or camera0, camera1, ... when it has none."""
    names = tuple(getattr(demo, "cameras", ()) or ())
    return names if len(names) == n_cams else tuple(f"camera{i}" for i in range(n_cams))


def _write_obs(group: Any, obs: Mapping[str, np.ndarray], cameras: Sequence[str]) -> None:
    for key, value in obs.items():
        value = np.asarray(value)
        if value.dtype == np.float64:
            value = value.astype(np.float32)
        if key == "rgb":
            for i, cam in enumerate(cameras):
                _dataset(group, f"{cam}_image", np.ascontiguousarray(value[:, i]), compress=True)
        elif key == "depth":
            for i, cam in enumerate(cameras):
                _dataset(group, f"{cam}_depth", np.ascontiguousarray(value[:, i, ..., None]),
                         compress=True)
        else:
            _dataset(group, key, value, compress=value.ndim >= 4)


def _next_obs(demo: Any) -> dict[str, np.ndarray]:
    """robomimic's next_obs: obs shifted by one step, then the final (or last) observation."""
    final = getattr(demo, "final_obs", None) or {}
    out = {}
    for key, value in demo.obs.items():
        value = np.asarray(value)
        last = np.asarray(final[key])[None] if key in final else value[-1:]
        out[key] = np.concatenate([value[1:], last.astype(value.dtype)])
    return out


def _write_demo(group: Any, demo: Any) -> None:
    T = len(demo)
    _dataset(group, "actions", np.asarray(demo.actions, np.float32))
    n_cams = int(np.shape(demo.obs["rgb"])[1]) if "rgb" in demo.obs else (
        int(np.shape(demo.obs["depth"])[1]) if "depth" in demo.obs else 0)
    cameras = camera_names(demo, n_cams)
    _write_obs(group.create_group("obs"), demo.obs, cameras)
    _write_obs(group.create_group("next_obs"), _next_obs(demo), cameras)
    states = getattr(demo, "states", None)
    if states is not None:
        _dataset(group, "states", np.asarray(states, np.float64))
    rewards = getattr(demo, "rewards", None)
    _dataset(group, "rewards", np.asarray(np.zeros(T) if rewards is None else rewards,
                                          np.float32))
    dones = np.zeros(T, np.int64)
    dones[-1] = 1
    _dataset(group, "dones", dones)
    instruction = getattr(demo, "instruction", "")
    group.attrs["num_samples"] = T
    group.attrs["task"] = demo.task
    group.attrs["source"] = demo.source
    group.attrs["instruction"] = instruction
    group.attrs["seed"] = int(getattr(demo, "seed", -1))
    group.attrs["ep_meta"] = json.dumps({"lang": instruction})  # RoboCasa's key
    if n_cams:
        group.attrs["cameras"] = json.dumps(list(cameras))
    for key, value in (getattr(demo, "meta", None) or {}).items():
        group.attrs[key] = value


def write_demos(path: str | Path, demos: Sequence[Demo], file_attrs: dict[str, Any] | None = None,
                valid_fraction: float = 0.1, split_seed: int = 0,
                names: Sequence[str] | None = None) -> Path:
    """Write demos to `path` atomically; return the path.

    `names` default to demo_0, demo_1, ...; `file_attrs` go onto the `data` group.
    """
    path = Path(path)
    names = list(names) if names is not None else [f"demo_{i}" for i in range(len(demos))]
    if len(names) != len(demos):
        raise ValueError(f"{len(names)} names for {len(demos)} demos")
    with _atomic_h5(path) as f:
        data = f.create_group("data")
        for name, demo in zip(names, demos, strict=True):
            _write_demo(data.create_group(name), demo)
        _finish_file(f, file_attrs or {}, valid_fraction, split_seed)
    return path


def _finish_file(f: Any, file_attrs: dict[str, Any], valid_fraction: float,
                 split_seed: int) -> None:
    data = f["data"]
    names = sorted_demo_names(data.keys())
    data.attrs["total"] = int(sum(int(data[n]["actions"].shape[0]) for n in names))
    data.attrs["format"] = FORMAT
    data.attrs["depth_units"] = DEPTH_UNITS
    for key, value in file_attrs.items():
        data.attrs[key] = json.dumps(value) if key == "env_args" else value
    masks = train_valid_split(names, valid_fraction=valid_fraction, seed=split_seed)
    group = f.require_group("mask")
    for key, members in masks.items():
        group.create_dataset(key, data=np.array(members, dtype="S"))


@contextlib.contextmanager
def _atomic_h5(path: Path) -> Iterator[Any]:
    """An h5py File written to `path` atomically (`fileio.atomic_path`)."""
    import h5py

    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        yield f


def merge_demo_files(path: str | Path, parts: Sequence[tuple[str | Path, str, str]],
                     file_attrs: dict[str, Any], valid_fraction: float = 0.1,
                     split_seed: int = 0) -> Path:
    """Atomically write `path` from (file, demo name there, demo name in `path`) `parts`.

    Demos in the current layout are copied bit for bit; `path` may be one of the inputs.
    """
    import h5py

    path = Path(path)
    with _atomic_h5(path) as out:
        data = out.create_group("data")
        opened: dict[str, Any] = {}
        try:
            for src, src_name, dst_name in parts:
                key = str(src)
                if key not in opened:
                    opened[key] = h5py.File(key, "r")
                group = opened[key]["data"][src_name]
                if "next_obs" in group:
                    opened[key].copy(group, data, name=dst_name)
                else:
                    demo = _read_demo(Path(key), src_name, group,
                                      _key_map(Path(key), src_name, group, None, own=True))
                    _write_demo(data.create_group(dst_name), demo)
        finally:
            for f in opened.values():
                f.close()
        _finish_file(out, file_attrs, valid_fraction, split_seed)
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


def _json(value: Any) -> Any:
    """`value` decoded from JSON where it is a JSON string, else as it is."""
    if isinstance(value, str):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    return value


def file_info(path: str | Path) -> dict[str, Any]:
    """The `data` group's attributes and demo names ("demos") of a file, without arrays."""
    import h5py

    path = Path(path)
    if not path.exists():
        raise _err(path, None, "file not found")
    if path.is_dir():
        raise _err(path, None, "is a folder, not a data set file")
    try:
        with h5py.File(path, "r") as f:
            if "data" not in f:
                raise _err(path, None, "no 'data' group (not a robomimic-layout file)")
            attrs = {k: _attr(f["data"].attrs, k) for k in f["data"].attrs}
            names = sorted_demo_names(k for k in f["data"].keys() if k.startswith("demo"))
    except OSError as exc:
        raise _err(path, None, f"not a readable HDF5 file ({exc})") from None
    except (RuntimeError, KeyError) as exc:
        raise _err(path, None, f"the file is damaged ({_damage(exc)})") from None
    if "env_args" in attrs:
        attrs["env_args"] = _json(attrs["env_args"])
    attrs["demos"] = names
    return attrs


def verify_file(path: str | Path, images: bool = True) -> dict[str, Any]:
    """Read every dataset of a file once (checking its checksums); return `file_info(path)`.

    `images=False` skips datasets of 4 or more dimensions. Raises DatasetError naming the
    first dataset that cannot be read.
    """
    import h5py

    path = Path(path)
    sig = memo.signature(path)  # unchanged bytes verified once per process (`memo`)
    info = memo.recall(sig, ("verified", True)) or memo.recall(sig, ("verified", images))
    if info is not None:
        return info
    info = file_info(path)
    where = ["the file"]

    def read(name: str, node: Any) -> None:
        if isinstance(node, h5py.Dataset) and (images or node.ndim < 4):
            where[0] = name
            node[()]

    try:
        with h5py.File(path, "r") as f:
            f.visititems(read)
    except H5_ERRORS as exc:
        raise _err(path, None, f"{where[0]} cannot be read: the file is damaged "
                               f"({_damage(exc)})") from None
    memo.keep(path, sig, ("verified", images), info)
    return info


def _damage(exc: BaseException) -> str:
    """h5py's error on a damaged file, with what it means when HDF5 does not say."""
    text = f"{type(exc).__name__}: {exc}"
    if "filter returned failure" in str(exc):
        text += "; a checksum does not match: the bytes changed after writing"
    return text


def _finite(path: Path, name: str, key: str, value: np.ndarray) -> None:
    if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
        bad = np.argwhere(~np.isfinite(value))[0]
        raise _err(path, name, f"{key} has NaN or infinite values (first at index {tuple(bad)})")


def _read(path: Path, name: str, group: Any, key: str, rows: slice = slice(None)) -> np.ndarray:
    """`group[key][rows]`, with h5py's errors on a damaged file turned into DatasetError."""
    try:
        return group[key][rows]
    except H5_ERRORS as exc:
        where = "/".join([*group.name.strip("/").split("/")[2:], key])  # relative to the demo
        raise _err(path, name, f"cannot read {where}: the file is damaged "
                               f"({_damage(exc)})") from None


def _available(group: Any) -> dict[str, tuple[tuple[int, ...], str]]:
    return {k: (tuple(v.shape), v.dtype.kind) for k, v in group.items() if hasattr(v, "shape")}


def _gather(path: Path, name: str, raw: Any, keys: ObsKeyMap, rows: slice,
            T: int) -> dict[str, np.ndarray]:
    """The project's observation entries of one demo from the file keys `keys` (rows `rows`)."""
    obs: dict[str, np.ndarray] = {}
    prefix = raw.name.split("/")[-1]
    for key in (*keys.proprio, *keys.object, *keys.rgb, *keys.depth):
        if key not in raw:
            raise _err(path, name, f"missing key '{prefix}/{key}'")
        if raw[key].shape[0] != T:
            raise _err(path, name, f"{prefix}/{key} has {raw[key].shape[0]} steps but actions "
                                   f"have {T}")
    for entry in ("proprio", "object"):
        parts = [_read(path, name, raw, k, rows) for k in getattr(keys, entry)]
        n = len(range(T)[rows])
        obs[entry] = (np.concatenate([p.reshape(n, -1).astype(np.float32) for p in parts],
                                     axis=1) if parts else np.zeros((n, 0), np.float32))
    for entry, file_keys in (("rgb", keys.rgb), ("depth", keys.depth)):
        arrays = []
        for k in file_keys:
            a = _read(path, name, raw, k, rows)
            if k == entry:  # stacked cameras (the layout's version 1)
                arrays.append(a)
                continue
            if entry == "rgb" and (a.ndim != 4 or a.shape[-1] != 3):
                raise _err(path, name, f"{prefix}/{k} must be (T, H, W, 3), got {a.shape}")
            if entry == "depth":  # (T, H, W) or (T, H, W, 1)
                a = a[..., 0] if a.ndim == 4 and a.shape[-1] == 1 else a
                if a.ndim != 3:
                    raise _err(path, name, f"{prefix}/{k} must be (T, H, W) or (T, H, W, 1)")
            arrays.append(a[:, None])  # one camera
        if len({a.shape[2:] for a in arrays}) > 1 or len({a.ndim for a in arrays}) > 1:
            raise _err(path, name, f"cameras {', '.join(f'{prefix}/{k}' for k in file_keys)} "
                                   f"have different image shapes {[a.shape[1:] for a in arrays]}")
        if arrays:
            obs[entry] = np.concatenate(arrays, axis=1)
    return obs


def _check_obs(path: Path, name: str, obs: dict[str, np.ndarray]) -> None:
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


_KNOWN_ATTRS = {"num_samples", "task", "source", "instruction", "seed", "ep_meta", "cameras"}


def _read_demo(path: Path, name: str, group: Any, keys: ObsKeyMap, file_task: str = "",
               file_source: str = "robomimic") -> Demo:
    """One demo of an open file, its observations gathered by `keys`; validated."""
    if "actions" not in group:
        raise _err(path, name, "missing key 'actions'")
    if "obs" not in group:
        raise _err(path, name, "missing key 'obs'")
    actions = _read(path, name, group, "actions")
    if actions.ndim != 2 or actions.shape[0] == 0:
        raise _err(path, name, f"actions must be (T, A) with T > 0, got {actions.shape}")
    T = actions.shape[0]
    _finite(path, name, "actions", actions)
    obs = _gather(path, name, group["obs"], keys, slice(None), T)
    _check_obs(path, name, obs)
    final = None
    if "next_obs" in group:
        final = {k: v[0] for k, v in _gather(path, name, group["next_obs"], keys,
                                             slice(-1, None), T).items()}
    states = _read(path, name, group, "states") if "states" in group else None
    if states is not None and states.shape[0] != T:
        raise _err(path, name, f"states have {states.shape[0]} steps but actions have {T}")
    rewards = _read(path, name, group, "rewards") if "rewards" in group else None
    attrs = group.attrs
    ep_meta = _json(_attr(attrs, "ep_meta"))
    lang = ep_meta.get("lang", "") if isinstance(ep_meta, dict) else ""
    cameras = tuple(camera_of(k) for k in keys.rgb or keys.depth
                    if k not in ("rgb", "depth"))
    return Demo(
        actions=actions.astype(np.float32),
        obs={k: (v.astype(np.float32) if v.dtype.kind == "f" else v) for k, v in obs.items()},
        task=str(_attr(attrs, "task", file_task)),
        source=str(_attr(attrs, "source", file_source)),
        instruction=str(_attr(attrs, "instruction", lang) or lang),
        seed=int(_attr(attrs, "seed", -1)),
        name=name,
        states=None if states is None else states.astype(np.float64),
        rewards=None if rewards is None else rewards.astype(np.float32),
        meta={k: _attr(attrs, k) for k in attrs if k not in _KNOWN_ATTRS},
        final_obs=final,
        cameras=cameras,
    )


def _file_task(info: Mapping[str, Any]) -> str:
    env_args = info.get("env_args") if isinstance(info.get("env_args"), dict) else {}
    ours = env_args.get("icil_paper") if isinstance(env_args.get("icil_paper"), dict) else {}
    return str(info.get("task") or ours.get("task") or env_args.get("env_name") or "")


def _check_limit(limit: Any) -> int | None:
    if limit is None:
        return None
    if isinstance(limit, bool) or not isinstance(limit, (int, np.integer)) or limit < 1:
        raise ValueError(f"limit must be a whole number of demos, at least 1 (or None for all), "
                         f"got {limit!r}")
    return int(limit)


def load_demos(path: str | Path, action_dim: int | None = None, limit: int | None = None,
               images: bool = True,
               obs_keys: Sequence[str] | Mapping[str, Sequence[str]] | None = None) -> list[Demo]:
    """Load and validate the demos of a robomimic-layout HDF5 file (ours or robomimic's).

    `limit` loads exactly the first `limit` demos (numeric order); `images=False` skips
    `rgb` / `depth`; `obs_keys` picks the file's observation keys (`data.obs_keys`; None: ours,
    or the default mapping, which warns naming the keys it drops). Raises DatasetError naming
    file, demo and problem (missing keys, shapes, action widths, NaNs, damaged data).
    """
    import h5py

    path = Path(path)
    limit = _check_limit(limit)
    sig = memo.signature(path) if obs_keys is None else None  # read once per process (`memo`)
    if (kept := memo.recall(sig, ("demos", action_dim, limit, images))) is not None:
        return kept
    info = file_info(path)
    names = info["demos"]
    if not names:
        raise _err(path, None, "no demos under 'data' (expected groups named demo_N)")
    if limit is not None:
        if len(names) < limit:
            raise _err(path, None, f"holds {len(names)} demos, {limit} were asked for")
        names = names[:limit]
    own = str(info.get("format", "")).startswith("icil_paper/") and obs_keys is None
    file_task, file_source = _file_task(info), str(info.get("source") or "robomimic")
    file_action_dim = info.get("action_dim")
    demos: list[Demo] = []
    first: tuple[int, int, int] | None = None  # (action, proprio, object) widths of demo 0
    keys: ObsKeyMap | None = None
    warned = False
    try:
        with h5py.File(path, "r") as f:
            for name in names:
                group = f["data"][name]
                if (keys is None or own) and "obs" in group:  # own files: cameras per demo
                    keys = _key_map(path, name, group, obs_keys, own)
                    if not images:
                        keys = keys.without_images()
                    if keys.dropped and obs_keys is None and not warned:
                        warned = True
                        warnings.warn(f"{path}: observation keys not used: "
                                      f"{', '.join(keys.dropped)} (using {keys.describe()}); "
                                      "choose keys with obs_keys (--obs-keys)", stacklevel=2)
                demo = _read_demo(path, name, group, keys or ObsKeyMap((), ()), file_task,
                                  file_source)
                A = demo.actions.shape[1]
                for what, want in (("the expected", action_dim),
                                   ("the file's action_dim attribute", file_action_dim)):
                    if want is not None and A != int(want):
                        raise _err(path, name, f"action dimension {A} does not match {what} "
                                               f"{int(want)}")
                dims = (A, demo.obs["proprio"].shape[1], demo.obs["object"].shape[1])
                first = first or dims
                if A != first[0]:
                    raise _err(path, name, f"action dimension {A} differs from the file's "
                                           f"first demo ({first[0]})")
                if dims[1:] != first[1:]:
                    raise _err(path, name, f"(proprio, object) widths {dims[1:]} differ from the "
                                           f"file's first demo {first[1:]}")
                demos.append(demo)
    except H5_ERRORS as exc:
        raise _err(path, None, f"the file is damaged ({_damage(exc)})") from None
    if not warned:
        memo.keep(path, sig, ("demos", action_dim, limit, images), demos)
    return demos


def _key_map(path: Path, name: str, group: Any, obs_keys: Any, own: bool) -> ObsKeyMap:
    cameras = _json(_attr(group.attrs, "cameras"))
    try:
        return map_obs_keys(_available(group["obs"]), obs_keys, own=own,
                            camera_order=cameras if isinstance(cameras, list) else None)
    except ValueError as exc:
        raise _err(path, name, str(exc)) from None


def read_masks(path: str | Path) -> dict[str, list[str]]:
    """robomimic's filter keys of a file (`mask/train`, `mask/valid`, ...) as lists of names."""
    import h5py

    with h5py.File(path, "r") as f:
        if "mask" not in f:
            return {}
        return {k: [n.decode() if isinstance(n, bytes) else str(n) for n in f["mask"][k][()]]
                for k in f["mask"]}
