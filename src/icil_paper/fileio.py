"""Files that are never half-written and never lost: atomic writes, damaged files set aside.

    atomic_write_json(path, obj)     # temporary file in the same folder, fsync, rename
    with atomic_path(path) as tmp: ...   # the same for a writer that wants a path (h5py)
    aside = set_aside(path)          # `<name>.corrupt-<time>-<random>` beside it, kept
    config = read_json(path, "a run config", fix="train the run again")   # one-line errors
    with exclusive_lock(folder / ".lock"):   # one writer at a time, across processes
        ...
    check_env_folder("ICIL_RESULTS", "results")   # writable? before any work, not after

Every file a command reads goes through `load_file` (or `read_json`): whatever a bad file
raises becomes one `UnreadableFileError` naming the file, what it should be and the fix.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import socket
import sys
import tempfile
import zipfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from typing import Any, TypeVar

from filelock import FileLock, Timeout

from icil_paper.config_data import json_default
from icil_paper.setup.provenance import REPO_ROOT


def folder_from_env(var: str, default: str) -> Path:
    """The folder $`var` names, else (also when blank) `default` under the repository root."""
    value = os.environ.get(var, "").strip()
    path = Path(value) if value else REPO_ROOT / default
    if path.exists() and not path.is_dir():
        where = f"${var}={value}" if value else str(path)
        raise NotADirectoryError(f"{where} is a file, not a folder: point ${var} at a folder "
                                 f"(it is created when missing), or unset it for {default}/")
    return path


def _umask() -> int:
    """The process umask, read without changing it where the system allows."""
    try:
        with open("/proc/self/status") as f:  # Linux: no window with a different umask
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside `path` to write; renamed onto `path` (fsync, `open`'s usual
    mode) when the block ends, removed when it raises."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write `data` to `path` atomically (`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_json(path: Path, obj: Any) -> None:
    """Atomically write `obj` as indented JSON (NaN is refused: it is not valid JSON)."""
    text = json.dumps(obj, indent=2, sort_keys=True, default=json_default, allow_nan=False)
    atomic_write_bytes(Path(path), (text + "\n").encode())


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, 64 hex digits (what records name their files by)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def set_aside(path: Path, folder: Path | None = None, why: str = "corrupt") -> Path | None:
    """Move a damaged file (or folder) to a new `<name>.<why>-<time>-<random>` name, in
    `folder` (default: beside it); nothing is deleted. Returns the new path, or None when the
    file is gone (another process set it aside first). `why="outdated"`: made by older code."""
    path = Path(path)
    try:
        is_dir = path.is_dir()
    except OSError:
        is_dir = False
    target = Path(folder) / path.name if folder is not None else path
    # the new name is created exclusively (an empty folder for a folder): never shared
    where = {"dir": target.parent, "prefix": f"{target.name}.{why}-"
             f"{datetime.now().strftime('%Y%m%d-%H%M%S')}-"}
    if is_dir:
        aside = Path(tempfile.mkdtemp(**where))
    else:
        fd, name = tempfile.mkstemp(**where)
        os.close(fd)
        aside = Path(name)
    try:
        os.replace(path, aside)
    except BaseException as exc:
        (aside.rmdir if is_dir else aside.unlink)()
        if isinstance(exc, FileNotFoundError):  # lost the race to another process
            return None
        raise
    return aside


# --------------------------------------------------------------------------- output folders
class FolderNotWritableError(PermissionError):
    """An output folder this process cannot write to; the message names it and the fix."""


def check_writable(path: Path, where: str | None = None, fix: str = "") -> None:
    """Raise FolderNotWritableError (or NotADirectoryError) unless the nearest existing folder
    at or above `path` takes a new file (tried with a temporary one); `where` names it."""
    path = Path(os.path.abspath(path))
    where = where or str(path)
    probe = path
    while True:
        try:
            if probe.exists() or probe == probe.parent:
                break
        except OSError:  # no permission to look: writing there fails the same way
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise NotADirectoryError(f"{where}: {probe} is a file, not a folder; {fix}".rstrip("; "))
    try:
        fd, tmp = tempfile.mkstemp(dir=probe, prefix=".write-test-")
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise FolderNotWritableError(f"cannot write to {where} ({exc.strerror or exc}); "
                                     f"{fix}".rstrip("; ")) from None


def check_env_folder(var: str, default: str) -> Path:
    """`folder_from_env(var, default)`, checked by `check_writable`."""
    path = folder_from_env(var, default)
    value = os.environ.get(var, "").strip()
    where = f"${var}={value}" if value else f"{path} (${var} is not set)"
    fix = f"point ${var} at a folder this user can write to" + (
        f", or unset it for {default}/" if value else "")
    check_writable(path, where, fix)
    return path


# --------------------------------------------------------------------------- reading files
T = TypeVar("T")


class UnreadableFileError(ValueError):
    """A file that cannot be read as what it should be; the message names it and the fix."""


READ_ERRORS: tuple[type[BaseException], ...] = (
    OSError, EOFError, ValueError, RuntimeError, KeyError, IndexError, TypeError,
    AttributeError, pickle.UnpicklingError, zipfile.BadZipFile)
"""What parsers raise on a bad file (a truncated torch file: RuntimeError, EOFError, OSError)."""


def one_line(exc: BaseException, limit: int | None = None) -> str:
    """`Type: the message's first line` (cut to `limit` characters), or the type alone."""
    text = (str(exc).strip().splitlines() or [""])[0][:limit]
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def load_file(path: str | Path, parse: Callable[[Path], T], what: str, fix: str,
              error: type[UnreadableFileError] = UnreadableFileError) -> T:
    """`parse(path)`; a bad file raises one `error` naming the file, `what` it should be ("a
    run config") and the `fix` ("train it again"); a missing one FileNotFoundError."""
    path = Path(path)
    try:
        return parse(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file; {fix}") from None
    except IsADirectoryError:
        raise error(f"{path} is a folder, not {what}; {fix}") from None
    except PermissionError as exc:
        raise error(f"cannot read {path} ({exc.strerror or exc}): give this user read "
                    f"access to it, or {fix}") from None
    except UnreadableFileError:
        raise
    except READ_ERRORS as exc:
        raise error(f"{path} is damaged or not {what} ({one_line(exc, 80)}); {fix}") from None


JSON_TYPES = {dict: "an object", list: "a list", str: "a string", int: "an integer",
              float: "a number", bool: "true or false", type(None): "null"}
"""How a field-type problem names each JSON type."""


def json_type_problem(obj: Any, fields: Mapping[str, type | tuple[type, ...]]) -> str | None:
    """Why the JSON object `obj` does not hold fields of the `fields` types ({name: type or
    types}; absent ones pass), or None. An int counts as a float, a bool as neither."""
    for name, types in fields.items():
        if name not in obj:
            continue
        types = types if isinstance(types, tuple) else (types,)
        value = obj[name]
        ok = any(isinstance(value, t) and not (isinstance(value, bool) and t is not bool)
                 or (t is float and isinstance(value, int) and not isinstance(value, bool))
                 for t in types)
        if not ok:
            wanted = " or ".join(JSON_TYPES.get(t, t.__name__) for t in types)
            found = JSON_TYPES.get(type(value), type(value).__name__)
            return f"its {name!r} is {found}, not {wanted}"
    return None


def read_json(path: str | Path, what: str, fix: str, keys: Sequence[str] = (),
              error: type[UnreadableFileError] = UnreadableFileError,
              fields: Mapping[str, type | tuple[type, ...]] | None = None) -> Any:
    """The JSON in `path`, read through `load_file`: an object holding `keys`, its `fields`
    of their types (`json_type_problem`), or one `error` naming the file and `fix`."""
    def parse(p: Path) -> Any:
        obj = json.loads(p.read_bytes().decode("utf-8"))
        if keys or fields:
            if not isinstance(obj, dict):
                raise ValueError(f"it holds a JSON {type(obj).__name__}, not an object")
            missing = [k for k in keys if k not in obj]
            if missing:
                raise KeyError(f"it has no {', '.join(repr(k) for k in missing)}")
            problem = json_type_problem(obj, fields or {})
            if problem:
                raise error(f"{p} is not {what} ({problem}); {fix}")
        return obj

    return load_file(path, parse, what, fix, error)


# --------------------------------------------------------------------------- one writer
class LockedError(RuntimeError):
    """A lock that another process holds, asked for without waiting."""


def _write_holder(fd: int) -> None:
    """What a waiter names: this process's pid, host and command line."""
    command = " ".join(Path(a).name if i == 0 else a for i, a in enumerate(sys.argv))[:200]
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()} ({command})\n".encode(), 0)


@contextmanager
def exclusive_lock(path: str | Path, what: str = "", wait: bool = True) -> Iterator[None]:
    """Hold an exclusive, re-entrant lock on the file `path` while the block runs
    (`filelock.FileLock`); a waiter prints the holder once. With `wait=False` a lock held
    elsewhere raises LockedError naming the holder."""
    path = Path(os.path.abspath(path))
    what = what or str(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = FileLock(path, is_singleton=True, on_acquired=_write_holder)
    try:
        lock.acquire(blocking=False)
    except Timeout:
        holder = _holder(path)
        if not wait:
            raise LockedError(f"{what} is in use by {holder}; wait for it to finish, or stop "
                              "it") from None
        print(f"waiting for {holder}, which holds {what}", file=sys.stderr, flush=True)
        lock.acquire()
    try:
        yield
    finally:
        if lock.lock_counter == 1:  # removed before it is let go: a waiter that locks the
            path.unlink(missing_ok=True)  # old file sees it unlinked and tries again
        lock.release()


def _holder(path: Path) -> str:
    try:
        return path.read_text(errors="replace").strip() or "another process"
    except OSError:
        return "another process"
