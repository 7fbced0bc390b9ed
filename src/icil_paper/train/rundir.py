"""Run folders and their files: config, checkpoints, metrics, the trained policy.

    runs/<preset>/<label>__<tasks>__<source>__seed<k>__<key8>/
        config.json          the run spec and its key
        checkpoint.pt        the latest checkpoint (model, optimizer, schedule, EMA, RNGs, step)
        checkpoint.prev.pt   the one before it (a truncated latest falls back to it)
        metrics.jsonl        one JSON line every `log_every` steps
        policy.pt            the trained policy (EMA weights if EMA is on)
        .lock                while a process writes here (`run_lock`; removed after)

One process writes a run folder at a time (`run_lock`). Every file is written atomically;
a damaged one is set aside with a warning and the run goes on from what is left. Policies
and checkpoints hold tensors, numbers and strings only (`torch.load(weights_only=True)`).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import random
import warnings
from collections.abc import Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import torch

from icil_paper.fileio import (
    UnreadableFileError,
    atomic_write_bytes,
    atomic_write_json,
    exclusive_lock,
    folder_from_env,
    load_file,
    read_json,
    set_aside,
)
from icil_paper.plugins import needed_by, record_of
from icil_paper.policies.factory import build_policy
from icil_paper.registry import UnknownNameError
from icil_paper.runspec import RunSpec, tasks_tag

RUNS_ENV_VAR = "ICIL_RUNS"
CHECKPOINT = "checkpoint.pt"
PREVIOUS_CHECKPOINT = "checkpoint.prev.pt"
POLICY_FILE = "policy.pt"
METRICS_FILE = "metrics.jsonl"
CONFIG_FILE = "config.json"
LOCK_FILE = ".lock"
POLICY_FORMAT = "icil_paper.policy/2"
CHECKPOINT_FORMAT = "icil_paper.checkpoint/2"


class RunFolderError(ValueError):
    """A run folder that cannot be used as asked; the message names the folder and the fix."""


class PolicyFileError(UnreadableFileError):
    """A file that is not a policy (or checkpoint) this version reads safely."""


class DamagedFileWarning(UserWarning):
    """A run file that could not be read; it was set aside and the run goes on without it."""


def runs_root() -> Path:
    """Root of run folders: $ICIL_RUNS (an empty value counts as unset), else `runs/`."""
    return folder_from_env(RUNS_ENV_VAR, "runs")


def run_dir_for(spec: Any, preset_name: str) -> Path:
    """`runs/<preset>/<label>__<tasks>__<source>__seed<k>__<key8>` for a RunSpec."""
    data = spec.data
    source = data.source if data.dataset is None else "file"
    return (runs_root() / preset_name
            / f"{spec.label}__{tasks_tag(data.tasks)}__{source}__seed{spec.seed}__{spec.key()[:8]}")


def set_aside_damaged(path: Path, problem: str) -> None:
    """Set a damaged run file aside (`fileio.set_aside`) and say so."""
    aside = set_aside(path)
    if aside is not None:
        warnings.warn(f"damaged file {path}: {problem}; moved to {aside.name}",
                      DamagedFileWarning, stacklevel=3)


# --------------------------------------------------------------------------- the folder
@contextmanager
def run_lock(run_dir: Path):
    """Hold the run folder's lock, the one writer of a run folder; the folder is created
    first (RunFolderError when it is a file or cannot be written)."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise RunFolderError(f"the run folder {run_dir} is a file; pass another --run-dir")
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        probe = run_dir / f".write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise RunFolderError(f"cannot write to the run folder {run_dir} ({exc.strerror}); "
                             "pass another --run-dir or set $ICIL_RUNS") from None
    with exclusive_lock(run_dir / LOCK_FILE, what=f"the run folder {run_dir}"):
        yield


def prepare_run_dir(run_dir: Path, spec: Any, resume: bool) -> None:
    """Check a run folder for `spec` and write its config.json; the caller holds `run_lock`.

    RunFolderError when resuming a folder of another run; without `resume`, an earlier run's
    files there are removed.
    """
    run_dir = Path(run_dir)
    for stale in run_dir.glob(".*.tmp"):  # temporary files of a killed write
        stale.unlink(missing_ok=True)
    key = spec.key()
    path = run_dir / CONFIG_FILE
    if resume and path.exists():
        try:
            old_key = read_config(run_dir)["key"]
        except UnreadableFileError as exc:
            set_aside_damaged(path, f"unreadable run config ({exc})")
        else:
            if old_key != key:
                raise RunFolderError(
                    f"{run_dir} holds a different run (key {old_key}, this run is {key}); "
                    "pass another --run-dir, or --no-resume to start over there")
    if not resume:
        for name in (METRICS_FILE, CHECKPOINT, PREVIOUS_CHECKPOINT, POLICY_FILE):
            (run_dir / name).unlink(missing_ok=True)
    atomic_write_json(path, {"key": key, "label": spec.label, "spec": spec.to_dict()})


def read_config(run_dir: Path) -> dict[str, Any]:
    """The config.json of a run folder: {"key", "label", "spec"}."""
    return read_json(Path(run_dir) / CONFIG_FILE, _CONFIG_WHAT, _config_fix(run_dir),
                     keys=("key", "spec"))


_CONFIG_WHAT = "a run folder's config.json (with its key and spec)"


def _config_fix(run_dir: Path) -> str:
    return f"train the run again (icil-paper train --run-dir {run_dir}) or restore the file"


def read_run_spec(run_dir: Path) -> Any:
    """The RunSpec of a run folder's config.json."""
    spec = read_config(run_dir)["spec"]
    try:
        return RunSpec.from_dict(spec)
    except (ValueError, TypeError) as exc:
        raise UnreadableFileError(f"{Path(run_dir) / CONFIG_FILE} is not {_CONFIG_WHAT} this "
                                  f"version reads ({exc}); {_config_fix(run_dir)}") from None


# --------------------------------------------------------------------------- RNG state
def rng_state(rng: np.random.Generator) -> dict[str, Any]:
    """Every random state a training run draws from, as tensors and JSON strings."""
    kind, keys, pos, has_gauss, cached = np.random.get_state()
    state = {"numpy": json.dumps(rng.bit_generator.state), "torch": torch.get_rng_state(),
             "python": json.dumps(random.getstate()),
             "numpy_global": json.dumps([kind, keys.tolist(), pos, has_gauss, cached])}
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def _cpu_bytes(tensor: torch.Tensor) -> torch.Tensor:
    # torch's RNG setters take CPU ByteTensors only; a checkpoint loaded with
    # map_location="cuda" (resuming on a GPU) holds its RNG states on the GPU.
    return tensor.to(device="cpu", dtype=torch.uint8)


def set_rng_state(rng: np.random.Generator, state: Mapping[str, Any]) -> None:
    rng.bit_generator.state = json.loads(state["numpy"])
    torch.set_rng_state(_cpu_bytes(state["torch"]))
    version, internal, gauss = json.loads(state["python"])
    random.setstate((version, tuple(internal), gauss))
    kind, keys, pos, has_gauss, cached = json.loads(state["numpy_global"])
    np.random.set_state((kind, np.asarray(keys, dtype=np.uint32), pos, has_gauss, cached))
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all([_cpu_bytes(t) for t in state["cuda"]])


# --------------------------------------------------------------------------- safe torch files
def save_tensors(path: Path, obj: Mapping[str, Any]) -> None:
    """torch.save of tensors / numbers / strings through bytes and an atomic rename."""
    buf = io.BytesIO()
    torch.save(dict(obj), buf)
    atomic_write_bytes(Path(path), buf.getvalue())


def load_tensors(path: Path, fmt: str, map_location: Any = "cpu") -> dict[str, Any]:
    """Read a file written by `save_tensors` with `weights_only=True`; PolicyFileError when
    it is damaged, not in format `fmt` or holds anything but tensors, numbers and strings."""
    blob = load_file(path, lambda p: torch.load(p, map_location=map_location, weights_only=True),
                     f"a {fmt} file this version reads safely",
                     "retrain it (`icil-paper train`) or restore the file", PolicyFileError)
    if not isinstance(blob, dict) or blob.get("format") != fmt:
        found = blob.get("format") if isinstance(blob, dict) else type(blob).__name__
        raise PolicyFileError(f"{path} is not a {fmt} file (found {found!r}); retrain it with "
                              "this version (`icil-paper train`)")
    return blob


def save_checkpoint(run_dir: Path, state: Mapping[str, Any]) -> None:
    """Write checkpoint.pt, keeping the one before as checkpoint.prev.pt."""
    current = Path(run_dir) / CHECKPOINT
    if current.exists():
        os.replace(current, Path(run_dir) / PREVIOUS_CHECKPOINT)
    save_tensors(current, {"format": CHECKPOINT_FORMAT, **state})


def load_checkpoint(run_dir: Path, key: str, map_location: Any = "cpu") -> dict[str, Any] | None:
    """The newest readable checkpoint of this run, or None; a damaged one is set aside and
    the previous one tried; one of another run raises RunFolderError."""
    for name in (CHECKPOINT, PREVIOUS_CHECKPOINT):
        path = Path(run_dir) / name
        if not path.exists():
            continue
        try:
            ckpt = load_tensors(path, CHECKPOINT_FORMAT, map_location)
        except PolicyFileError as exc:
            set_aside_damaged(path, str(exc))
            continue
        if ckpt.get("key") != key:
            raise RunFolderError(f"{path} is a checkpoint of another run (key {ckpt.get('key')},"
                                 f" this run is {key}); pass --no-resume to start over")
        return ckpt
    return None


def save_policy(path: Path, policy: Any, meta: Mapping[str, Any]) -> None:
    """Write a trained policy: its spec (JSON), its weights and `meta` (JSON)."""
    used = record_of(policy.spec)  # the plugins that loading it needs, named on failure
    meta = {**meta, "plugins": used} if used else dict(meta)
    save_tensors(Path(path), {"format": POLICY_FORMAT, "spec": json.dumps(policy.spec),
                              "meta": json.dumps(meta), "state_dict": policy.state_dict()})


def load_policy(path: str | Path, map_location: Any = "cpu"):
    """The trained policy in a run folder or `policy.pt` file, in eval mode."""
    path = Path(path)
    if path.is_dir():
        path = path / POLICY_FILE
    if not path.exists():
        raise FileNotFoundError(f"no trained policy at {path} (train it first: icil-paper train)")
    blob = load_tensors(path, POLICY_FORMAT, map_location)
    try:
        policy = build_policy(json.loads(blob["spec"]))
        policy.load_state_dict(blob["state_dict"])
    except UnknownNameError as exc:
        needs = json.loads(blob.get("meta") or "{}").get("plugins")
        if not needs:
            raise PolicyFileError(f"{path}: {exc}") from None
        raise PolicyFileError(f"{path} needs the plugin {needed_by(needs)}, which is not "
                              f"loaded: pass --plugin {needs[0].get('path') or needs[0]['spec']}"
                              " (or icil_paper.plugins.load_plugins first)") from None
    except (KeyError, ValueError, RuntimeError, TypeError) as exc:
        raise PolicyFileError(f"{path}: its weights do not fit its spec ({exc})") from None
    policy.meta = json.loads(blob.get("meta") or "{}")
    return policy.eval()


def policy_digest(policy: Any) -> str:
    """A short hash of a policy's weights (identifies a trained policy in result records)."""
    h = hashlib.sha256()
    for k, v in sorted(policy.state_dict().items()):
        h.update(k.encode())
        if isinstance(v, torch.Tensor):
            h.update(v.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()[:16]


# --------------------------------------------------------------------------- metrics
def read_metrics(path: Path) -> list[dict[str, Any]]:
    """The metric lines of a run; torn, damaged or non-object lines are dropped."""
    if not Path(path).exists():
        return []
    raw = load_file(path, Path.read_bytes, "a metrics file",
                    "remove it (the run's metric lines are then written anew)")
    lines = []
    for text in raw.splitlines():
        if not text.strip():
            continue
        try:
            line = json.loads(text.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError):
            continue
        if isinstance(line, dict) and isinstance(line.get("step"), int):
            lines.append(line)
    return lines


def truncate_metrics(path: Path, step: int) -> None:
    """Keep the readable metric lines up to `step` (the lines after a checkpoint are redone)."""
    keep = [line for line in read_metrics(path) if line.get("step", 0) <= step]
    if Path(path).exists():
        atomic_write_bytes(Path(path), "".join(json.dumps(x) + "\n" for x in keep).encode())


def append_metrics(path: Path, line: Mapping[str, Any]) -> None:
    with open(path, "a") as f:
        f.write(json.dumps(dict(line)) + "\n")
