"""The results store: one JSON record per run under `results/<preset>/<kind>/`.

Each record carries its config, config hash, seed, git commit, package versions, host, wall
time and metrics, and is written atomically. A run whose config hash has a valid record is
skipped unless forced; a corrupt record (unreadable, incomplete, tampered with, a non-finite
metric) is reported, set aside (never deleted) and recomputed. `run` holds the record's lock
while it computes, so a second process asking for it waits and reads what the first wrote.
A record that stands for files names them with their SHA-256 (`files`, `files_problem`).

    store = ResultsStore("small")
    record = store.run("tokenizer", "lipvq", config, lambda: {"recon_mse": 0.01})
    table = store.table("tokenizer")          # a pandas DataFrame for notebooks
"""

from __future__ import annotations

import json
import math
import numbers
import os
import time
import warnings
from collections.abc import Callable, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from icil_paper import plugins
from icil_paper.config_data import canonical_json, content_hash
from icil_paper.fileio import (
    atomic_write_json,
    exclusive_lock,
    file_sha256,
    folder_from_env,
    json_type_problem,
    read_json,
    set_aside,
)
from icil_paper.setup.provenance import git_state, host_info, package_versions

SCHEMA_VERSION = 1
RESULTS_ENV_VAR = "ICIL_RESULTS"
REQUIRED_KEYS = ("schema", "kind", "name", "preset", "config", "config_hash", "seed",
                 "git_commit", "packages", "host", "wall_time_s", "metrics")
FIELD_TYPES: dict[str, type | tuple[type, ...]] = {
    "schema": int, "kind": str, "name": str, "preset": str, "config": dict,
    "config_hash": str, "seed": int, "git_commit": (str, type(None)), "packages": dict,
    "host": dict, "wall_time_s": float, "cpu_time_s": float, "metrics": dict, "files": dict}
"""The JSON type of every field a record may hold (another type: the record is corrupt)."""


class CorruptRecordWarning(UserWarning):
    """A result file that cannot be trusted (unreadable, incomplete or tampered with)."""


def results_root() -> Path:
    """Root of the store: $ICIL_RESULTS (blank counts as unset), else `results/`."""
    return folder_from_env(RESULTS_ENV_VAR, "results")


def bench_path(name: str) -> Path:
    """`results/bench/<name>.json` of the results folder in use, else the committed one."""
    path = results_root() / "bench" / f"{name}.json"
    committed = Path(__file__).resolve().parents[2] / "results" / "bench" / f"{name}.json"
    return path if path.exists() else committed


def save_benchmark(name: str, record: dict[str, Any], out: str | Path | None = None) -> Path:
    """Write a measurement `record` with its provenance atomically to `out` (default
    results/bench/<name>.json); returns the path."""
    record = {"benchmark": name, **record, "load_average_1min": os.getloadavg()[0],
              "git": git_state(), "packages": package_versions(), "host": host_info()}
    path = Path(out) if out else results_root() / "bench" / f"{name}.json"
    atomic_write_json(path, record)
    print(f"wrote {path}")
    return path


def config_hash(config: Mapping[str, Any]) -> str:
    """16 hex digits of a JSON-ready config (`config_data.content_hash`)."""
    return content_hash(config)


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process and its finished children."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


class ResultsStore:
    """Records of one preset: `results/<preset>/<kind>/<name>__<config hash>.json`."""

    def __init__(self, preset: str, root: Path | None = None):
        self.preset = preset
        self.root = Path(root) if root is not None else results_root()
        self.dir = self.root / preset

    def path_for(self, kind: str, name: str, chash: str) -> Path:
        return self.dir / _slug(kind) / f"{_slug(name)}__{chash}.json"

    def record_path(self, kind: str, name: str, config: Mapping[str, Any]) -> Path:
        """Where the record of (kind, name, config) lives: `store.record_path(*record_id)`."""
        return self.path_for(kind, name, config_hash(config))

    def lock(self, kind: str, name: str, config: Mapping[str, Any]):
        """The lock of one record (`fileio.exclusive_lock`): its one writer at a time."""
        path = self.record_path(kind, name, config)
        return exclusive_lock(path.with_name(f".{path.stem}.lock"), what=f"the record {path}")

    def get(self, kind: str, name: str, config: Mapping[str, Any]) -> dict[str, Any] | None:
        """The valid record of this run, or None (a corrupt one is reported and set aside)."""
        chash = config_hash(config)
        return self._read(self.path_for(kind, name, chash), chash)

    def write(self, kind: str, name: str, config: Mapping[str, Any], metrics: Mapping[str, Any],
              seed: int, wall_time_s: float, extra: Mapping[str, Any] | None = None,
              cpu_time_s: float | None = None) -> Path:
        """Atomically write one record and return its path."""
        bad = _non_finite(dict(metrics))
        if bad is not None:
            raise ValueError(f"metric {bad[0]} is {bad[1]}; a result with a non-finite metric "
                             "is not stored (fix the run, or store None explicitly)")
        chash = config_hash(config)
        git = git_state()
        record = {
            "schema": SCHEMA_VERSION,
            "kind": kind,
            "name": name,
            "preset": self.preset,
            "config": json.loads(canonical_json(config)),
            "config_hash": chash,
            "seed": seed,
            "git_commit": git["commit"],
            "git_dirty": git["dirty"],
            "packages": package_versions(),
            "host": host_info(),
            "finished": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "wall_time_s": round(float(wall_time_s), 3),
            **({} if cpu_time_s is None else {"cpu_time_s": round(float(cpu_time_s), 3)}),
            "metrics": dict(metrics),
            **(dict(extra) if extra else {}),
        }
        used = plugins.record_of(record["config"])  # which plugin (version, digest) made it
        if used:
            record["plugins"] = used
        path = self.path_for(kind, name, chash)
        atomic_write_json(path, record)
        return path

    def run(self, kind: str, name: str, config: Mapping[str, Any],
            compute: Callable[[], Mapping[str, Any]], seed: int | None = None,
            force: bool = False,
            files: Callable[[], Mapping[str, str | Path]] | None = None) -> dict[str, Any]:
        """The stored record of this run, or compute it (holding its `lock`), store it and
        return it. `compute()` returns the metrics (raising: nothing is written); `files()`
        names the files the record stands for ({name: path})."""
        if not force:
            record = self.get(kind, name, config)
            if record is not None:
                return record
        with self.lock(kind, name, config):
            if not force:  # another process may have stored it while this one waited
                record = self.get(kind, name, config)
                if record is not None:
                    return record
            if seed is None:
                seed = int(config.get("seed", 0)) if isinstance(config, Mapping) else 0
            start, cpu = time.perf_counter(), cpu_seconds()
            metrics = compute()
            extra = None
            if files is not None:
                extra = {"files": {str(k): file_sha256(v) for k, v in files().items()}}
            path = self.write(kind, name, config, metrics, seed, time.perf_counter() - start,
                              extra, cpu_time_s=cpu_seconds() - cpu)
        return json.loads(path.read_text())

    def records(self, kind: str | None = None) -> list[dict[str, Any]]:
        """Every valid record (of one kind, if given); corrupt ones are reported and skipped."""
        pattern = f"{_slug(kind)}/*.json" if kind else "*/*.json"
        records = (self._read(path) for path in sorted(self.dir.glob(pattern)))
        return [record for record in records if record is not None]

    def table(self, kind: str | None = None):
        """The records as a pandas DataFrame: one row per run, metrics as columns."""
        import pandas as pd

        rows = []
        for r in self.records(kind):
            row = {"kind": r["kind"], "name": r["name"], "seed": r["seed"],
                   "config_hash": r["config_hash"], "git_commit": r["git_commit"],
                   "wall_time_s": r["wall_time_s"]}
            row.update({k: v for k, v in r["metrics"].items() if not isinstance(v, (dict, list))})
            rows.append(row)
        return pd.DataFrame(rows)

    def _read(self, path: Path, chash: str | None = None) -> dict[str, Any] | None:
        """The valid record in `path` (of config hash `chash`), or None: missing (never
        written, or set aside by another process meanwhile), or corrupt and set aside."""
        try:
            record, problem, identity = _read_record(path)
        except FileNotFoundError:
            return None
        if problem is None and chash is not None and record["config_hash"] != chash:
            problem = f"config hash {record['config_hash']} does not match {chash}"
        if problem is not None:
            self._set_aside(path, problem, identity)
            return None
        return record

    def _set_aside(self, path: Path, problem: str, identity: tuple[int, int] | None) -> None:
        """Move the corrupt file read as `identity` (device, inode) aside, unless another
        process has set it aside or replaced it meanwhile."""
        try:
            st = os.stat(path)
        except FileNotFoundError:
            return
        if identity is not None and (st.st_dev, st.st_ino) != identity:
            return
        try:
            aside = set_aside(path)
        except OSError as exc:  # a read-only store (`icil-paper tables` on a mount)
            warnings.warn(f"corrupt result {path}: {problem}; it is skipped (it could not be "
                          f"moved aside: {exc.strerror or exc})", CorruptRecordWarning,
                          stacklevel=4)
            return
        if aside is None:  # lost the race to another process
            return
        warnings.warn(f"corrupt result {path}: {problem}; moved to {aside.name} and it will "
                      "be recomputed", CorruptRecordWarning, stacklevel=4)


def files_problem(record: Mapping[str, Any], folder: str | Path) -> str | None:
    """Why the record's `files` ({name: SHA-256}) in `folder` are not the ones it was written
    with (missing or changed), or None (also for a record without `files`)."""
    for name, digest in (record.get("files") or {}).items():
        try:
            found = file_sha256(Path(folder) / name)
        except FileNotFoundError:
            return f"{name} is missing"
        except OSError as exc:
            return f"{name} cannot be read ({exc.strerror or exc})"
        if found != digest:
            return (f"{name} is not the file the record was written with (SHA-256 "
                    f"{found[:12]}.., the record's {str(digest)[:12]}..)")
    return None


RECORD_FIX = ("move it out of the results folder (the command that needs it computes it "
              "again) or restore it from git")
"""What to do about a damaged record that a command reads without setting it aside."""


def read_record_file(path: str | Path) -> dict[str, Any]:
    """The JSON object of a record file (UnreadableFileError for a damaged one)."""
    return read_json(path, "a result record (a JSON object)", RECORD_FIX, fields=FIELD_TYPES)


def _read_record(path: Path) -> tuple[dict[str, Any] | None, str | None,
                                      tuple[int, int] | None]:
    """(record, None, identity) for a valid record, (None, problem, identity) otherwise;
    identity is the file's (device, inode). FileNotFoundError propagates."""
    identity = None
    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            identity = (st.st_dev, st.st_ino)
            record = json.loads(f.read().decode())
    except FileNotFoundError:
        raise
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return None, f"unreadable JSON ({exc})", identity
    if not isinstance(record, dict):
        return None, "not a JSON object", identity
    missing = [k for k in REQUIRED_KEYS if k not in record]
    if missing:
        return None, f"missing keys {missing}", identity
    problem = json_type_problem(record, FIELD_TYPES)
    if problem is None and not all(isinstance(k, str) and isinstance(v, str)
                                   for k, v in record.get("files", {}).items()):
        problem = "its 'files' are not {name: SHA-256}"
    if problem is not None:
        return None, problem, identity
    if record["schema"] != SCHEMA_VERSION:
        return None, f"schema {record['schema']} is not {SCHEMA_VERSION}", identity
    if config_hash(record["config"]) != record["config_hash"]:
        return None, "its config does not hash to its config_hash", identity
    bad = _non_finite(record["metrics"])
    if bad is not None:
        return None, f"metric {bad[0]} is {bad[1]} (a stored metric must be finite)", identity
    return record, None, identity


def _non_finite(value: Any, where: str = "") -> tuple[str, float] | None:
    """(location like `per_task[3]['success']`, value) of the first NaN or inf, or None."""
    if hasattr(value, "tolist") and not isinstance(value, numbers.Number):
        value = value.tolist()  # numpy arrays, torch tensors
    if isinstance(value, Mapping):
        items = ((f"{where}[{key!r}]" if where else repr(key), item)
                 for key, item in value.items())
    elif isinstance(value, (list, tuple)):
        items = ((f"{where}[{i}]", item) for i, item in enumerate(value))
    else:
        real = isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral)
        return (where, float(value)) if real and not math.isfinite(float(value)) else None
    return next((found for at, item in items if (found := _non_finite(item, at)) is not None),
                None)
