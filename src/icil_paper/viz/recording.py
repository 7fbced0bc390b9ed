"""Recordings of demonstrations and rollouts: a rerun `.rrd` file and a static picture beside it.

    from icil_paper.viz.recording import record_episode
    paths = record_episode("runs/demo.rrd", demo.obs, demo.actions, latents=z)
    # paths["rrd"]: open with `rerun runs/demo.rrd`;  paths["png"]: the same episode, static

The `.rrd` file is written offline (no viewer is spawned), on a `step` timeline:

    actions/<dim>        one scalar series per action dim (dx, dy, dz, rx, ry, rz, gripper)
    world/eef            the end-effector position (proprio[:3]) and its whole path
    world/object         the object position, when `object_position` says where it is in obs
    latents/<i>          the first `MAX_LATENT_SERIES` dims of a tokenizer's latents, if given
    camera/<i>           camera images, if given (or found as obs["rgb"])

The static picture (matplotlib PNG) shows the same, for a reader without the rerun viewer.
"""

from __future__ import annotations

import io
import os
import uuid
import warnings
from collections.abc import Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper.fileio import atomic_write_bytes

ACTION_NAMES = ("dx", "dy", "dz", "rx", "ry", "rz", "gripper")
MAX_LATENT_SERIES = 8


def _stack_obs(obs_seq: Mapping[str, Any] | Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    if isinstance(obs_seq, Mapping):
        return {k: np.asarray(v) for k, v in obs_seq.items()}
    obs_seq = list(obs_seq)
    if not obs_seq:
        return {}
    return {k: np.stack([np.asarray(o[k]) for o in obs_seq]) for k in obs_seq[0]}


def _images(images: Any, obs: dict[str, np.ndarray]) -> np.ndarray | None:
    """Images as (T, n_cams, H, W, 3) uint8, or None."""
    if images is None:
        images = obs.get("rgb")
    if images is None:
        return None
    images = np.asarray(images)
    if images.ndim == 4:
        images = images[:, None]
    if images.ndim != 5 or images.shape[-1] != 3:
        raise ValueError(f"images must be (T, H, W, 3) or (T, n_cams, H, W, 3), got {images.shape}")
    return images.astype(np.uint8)


def _action_names(n: int) -> list[str]:
    return list(ACTION_NAMES) if n == len(ACTION_NAMES) else [f"a{i}" for i in range(n)]


@contextmanager
def _rrd_stream(path: Path, title: str = ""):
    """A rerun stream, titled, saving to a temporary file that becomes `path` on success."""
    import rerun as rr

    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    rec = rr.RecordingStream("icil_paper", recording_id=uuid.uuid4())
    rec.save(str(tmp))
    finished = False
    try:
        if title:
            rec.log("episode", rr.TextDocument(title), static=True)
        yield rec
        rec.flush()
        finished = True
    finally:
        rec.disconnect()  # close the file on failure too, before it is removed
        if finished:
            os.replace(tmp, path)
        elif tmp.exists():
            tmp.unlink()


def _try_rrd(path: Path, write: Any) -> bool:
    """Run `write` (a rerun recording to `path`); False, with a warning, where it fails."""
    try:
        write()
        return True
    except Exception as exc:  # noqa: BLE001 - the picture is the fallback
        warnings.warn(f"rerun recording {path} failed ({type(exc).__name__}: {exc}); "
                      "writing the static picture only", stacklevel=3)
        return False


def _save_png(fig: Any, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    atomic_write_bytes(path, buf.getvalue())


def _write_rrd(path: Path, obs: dict[str, np.ndarray], actions: np.ndarray,
               latents: np.ndarray | None, images: np.ndarray | None, title: str) -> None:
    import rerun as rr

    with _rrd_stream(path, title) as rec:
        eef = obs.get("proprio")
        if eef is not None and eef.shape[-1] >= 3:
            rec.log("world/eef_path", rr.LineStrips3D([eef[:, :3]]), static=True)
        names = _action_names(actions.shape[1])
        for t in range(actions.shape[0]):
            rec.set_time("step", sequence=t)
            for i, name in enumerate(names):
                rec.log(f"actions/{name}", rr.Scalars(float(actions[t, i])))
            if eef is not None and eef.shape[-1] >= 3:
                rec.log("world/eef", rr.Points3D([eef[t, :3]], radii=0.01))
            obj = obs.get("object_position")
            if obj is not None and obj.shape[-1] == 3:
                rec.log("world/object", rr.Points3D([obj[t]], radii=0.015))
            if latents is not None:
                for i in range(min(latents.shape[1], MAX_LATENT_SERIES)):
                    rec.log(f"latents/{i}", rr.Scalars(float(latents[t, i])))
            if images is not None:
                for c in range(images.shape[1]):
                    rec.log(f"camera/{c}", rr.Image(images[t, c]))


def _write_png(path: Path, obs: dict[str, np.ndarray], actions: np.ndarray,
               latents: np.ndarray | None, images: np.ndarray | None, title: str) -> None:
    from matplotlib.figure import Figure  # no pyplot: the caller's backend stays as it is

    eef = obs.get("proprio")
    rows = 2 + (latents is not None) + (images is not None)
    fig = Figure(figsize=(10, 2.6 * rows), constrained_layout=True)
    grid = fig.add_gridspec(rows, 2)
    ax = fig.add_subplot(grid[0, :])
    names = _action_names(actions.shape[1])
    for i, name in enumerate(names):
        ax.plot(actions[:, i], label=name, lw=1.2)
    ax.set(xlabel="step", ylabel="action", title=title or "episode")
    ax.legend(ncol=len(names), fontsize=7, loc="upper right")
    if eef is not None and eef.shape[-1] >= 3:
        top, side = fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1])
        top.plot(eef[:, 0], eef[:, 1], "-", color="tab:blue")
        top.plot(*eef[0, :2], "o", color="tab:green", label="start")
        top.plot(*eef[-1, :2], "s", color="tab:red", label="end")
        top.set(xlabel="x [m]", ylabel="y [m]", title="end effector, from above")
        top.set_aspect("equal", adjustable="datalim")
        top.legend(fontsize=7)
        side.plot(eef[:, 2], color="tab:blue", label="eef z")
        obj = obs.get("object_position")
        if obj is not None and obj.shape[-1] == 3:
            side.plot(obj[:, 2], color="tab:orange", label="object z")
            top.plot(obj[:, 0], obj[:, 1], ":", color="tab:orange", label="object")
        side.set(xlabel="step", ylabel="z [m]", title="height")
        side.legend(fontsize=7)
    row = 2
    if latents is not None:
        ax = fig.add_subplot(grid[row, :])
        for i in range(min(latents.shape[1], MAX_LATENT_SERIES)):
            ax.plot(latents[:, i], lw=1)
        ax.set(xlabel="step", ylabel="latent", title=f"latents (first {MAX_LATENT_SERIES} dims)")
        row += 1
    if images is not None:
        strip = fig.add_subplot(grid[row, :])
        picks = np.linspace(0, images.shape[0] - 1, num=min(5, images.shape[0])).astype(int)
        frames = [np.concatenate(list(images[t]), axis=0) for t in picks]  # cameras stacked
        strip.imshow(np.concatenate(frames, axis=1))
        strip.set(title=f"camera frames at steps {picks.tolist()}")
        strip.axis("off")
    _save_png(fig, path)


def record_episode(path: str | Path, obs_seq: Mapping[str, Any] | Sequence[Mapping[str, Any]],
                   actions: Any, latents: Any = None, images: Any = None, title: str = "",
                   rrd: bool = True, object_position: tuple[int, int] | None = None
                   ) -> dict[str, Path | None]:
    """Write a rerun recording of an episode to `path` (.rrd) and a PNG beside it.

    `obs_seq`: a dict of (T, ...) arrays or a list of T observation dicts; `actions` (T, A);
    `latents` (T, D); `images` (T, H, W, 3) or (T, n_cams, H, W, 3) uint8 (default
    obs["rgb"]); `object_position`: (start, stop) of the object's position in obs["object"];
    `rrd=False` writes only the picture. Returns {"rrd": path or None (failed, with a
    warning), "png": path}.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    obs = _stack_obs(obs_seq)
    actions = np.asarray(actions, dtype=np.float32)
    if actions.ndim != 2:
        raise ValueError(f"actions must be (T, A), got shape {actions.shape}")
    lat = None if latents is None else np.asarray(latents, dtype=np.float32).reshape(
        actions.shape[0], -1)
    imgs = _images(images, obs)
    if object_position is not None and "object" in obs:
        start, stop = object_position
        obs["object_position"] = obs["object"][:, start:stop]
    for key, value in {**obs, "images": imgs}.items():
        if value is not None and value.shape[0] != actions.shape[0]:
            raise ValueError(f"{key} has {value.shape[0]} steps but actions have "
                             f"{actions.shape[0]}")
    written = rrd and _try_rrd(path, lambda: _write_rrd(path, obs, actions, lat, imgs, title))
    _write_png(path.with_suffix(".png"), obs, actions, lat, imgs, title)
    return {"rrd": path if written else None, "png": path.with_suffix(".png")}


def principal_view(z: Any, dims: int = 3) -> np.ndarray:
    """The first `dims` principal components of z (T, D): (T, dims), zero-padded."""
    z = np.asarray(z, dtype=np.float64)
    if z.ndim != 2 or len(z) < 2:
        raise ValueError(f"z must be (T, D) with T >= 2, got shape {z.shape}")
    z = z - z.mean(0)
    _, _, vt = np.linalg.svd(z, full_matrices=False)
    view = z @ vt[:dims].T
    return np.pad(view, ((0, 0), (0, dims - view.shape[1])))


def _unit_extent(view: np.ndarray) -> np.ndarray:
    """A view rescaled so that its largest coordinate range is 1 (latent scales differ)."""
    extent = float(np.ptp(view, axis=0).max())
    return view / extent if extent > 0 else view


def record_latent_trajectories(path: str | Path, actions: Any, views: Mapping[str, Any],
                               title: str = "", rrd: bool = True) -> dict[str, Path | None]:
    """Write one action trajectory (T, A) through several latent spaces (`views`: {label:
    (T, 2 or 3)}, e.g. `principal_view(z)`) as `.rrd` and `.png`: each path scaled to unit
    extent, side by side, with a point moving along it. Returns {"rrd": path or None, "png"}.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    actions = np.asarray(actions, dtype=np.float32)
    if actions.ndim != 2:
        raise ValueError(f"actions must be (T, A), got shape {actions.shape}")
    if not views:
        raise ValueError("views is empty: give at least one {label: (T, k)} latent trajectory")
    unit = {}
    for label, view in views.items():
        view = np.asarray(view, dtype=np.float32)
        if view.ndim != 2 or view.shape[0] != actions.shape[0] or not 2 <= view.shape[1] <= 3:
            raise ValueError(f"view {label!r} must be (T={actions.shape[0]}, 2 or 3), "
                             f"got shape {view.shape}")
        unit[label] = _unit_extent(np.pad(view, ((0, 0), (0, 3 - view.shape[1]))))
    written = rrd and _try_rrd(path, lambda: _write_latent_rrd(path, actions, unit, title))
    _write_latent_png(path.with_suffix(".png"), unit, title)
    return {"rrd": path if written else None, "png": path.with_suffix(".png")}


def _write_latent_rrd(path: Path, actions: np.ndarray, unit: Mapping[str, np.ndarray],
                      title: str) -> None:
    import rerun as rr

    offsets = {label: np.array([1.5 * i, 0.0, 0.0], np.float32) for i, label in enumerate(unit)}
    with _rrd_stream(path, title) as rec:
        for label, view in unit.items():
            rec.log(f"latents/{label}/path", rr.LineStrips3D([view + offsets[label]],
                                                             labels=[label]), static=True)
        names = _action_names(actions.shape[1])
        for t in range(actions.shape[0]):
            rec.set_time("step", sequence=t)
            for i, name in enumerate(names):
                rec.log(f"actions/{name}", rr.Scalars(float(actions[t, i])))
            for label, view in unit.items():
                rec.log(f"latents/{label}/now", rr.Points3D([view[t] + offsets[label]],
                                                            radii=0.03))


def _write_latent_png(path: Path, unit: Mapping[str, np.ndarray], title: str) -> None:
    from matplotlib.figure import Figure  # no pyplot: the caller's backend stays as it is

    fig = Figure(figsize=(2.2 * len(unit), 2.6), constrained_layout=True)
    axes = fig.subplots(1, len(unit), squeeze=False)[0]
    for ax, (label, view) in zip(axes, unit.items(), strict=True):
        ax.plot(view[:, 0], view[:, 1], "-", color="0.7", lw=0.8)
        ax.scatter(view[:, 0], view[:, 1], c=np.arange(len(view)), cmap="viridis", s=8)
        ax.set_title(label, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    if title:
        fig.suptitle(title, fontsize=10)
    _save_png(fig, path)
