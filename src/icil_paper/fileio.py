"""Files that are never half-written and never lost: atomic writes, damaged files set aside.

    atomic_write_json(path, obj)     # temporary file in the same folder, fsync, rename
    aside = set_aside(path)          # `<name>.corrupt-<time>[-k]` beside it, never overwritten

Used by the results store, run folders and data sets alike.
"""

from __future__ import annotations

import json
import os
import tempfile
from datetime import datetime
from pathlib import Path
from typing import Any

from icil_paper.specs import json_default


def folder_from_env(var: str, default: str) -> Path:
    """The folder $`var` names, else (also when it is empty or blank) `default` under the
    repository root. NotADirectoryError, naming the variable, when it is a file."""
    from icil_paper.provenance import REPO_ROOT

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


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write `data` to `path` through a temporary file in the same folder and a rename.

    The file gets the mode an ordinary `open(path, "w")` would give it (0o666 minus the
    umask), not the 0o600 of the temporary file; it is set before the rename, so the file
    appears complete and with its final mode at once.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_json(path: Path, obj: Any) -> None:
    """Atomically write `obj` as indented JSON (NaN is refused: it is not valid JSON)."""
    text = json.dumps(obj, indent=2, sort_keys=True, default=json_default, allow_nan=False)
    atomic_write_bytes(Path(path), (text + "\n").encode())


def reserve_aside_name(path: Path, is_dir: bool = False) -> Path:
    """Create, exclusively, an empty `<name>.corrupt-<time>[-k]` beside `path`.

    The time has microseconds, and a name already taken gets the next free suffix; the
    exclusive create makes the name this caller's alone, so a set-aside file is never
    overwritten, not even by another process in the same microsecond. (An empty folder is
    reserved for a folder, since only that can be replaced by one.)
    """
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S-%f")
    for k in range(1, 10_000):
        aside = path.with_name(f"{path.name}.corrupt-{stamp}" + (f"-{k}" if k > 1 else ""))
        try:
            if is_dir:
                os.mkdir(aside)
            else:
                with open(aside, "x"):
                    pass
            return aside
        except FileExistsError:
            continue
    raise RuntimeError(f"no free name to set {path} aside under")  # pragma: no cover


def set_aside(path: Path, folder: Path | None = None) -> Path | None:
    """Move a damaged file (or folder) to a unique `<name>.corrupt-<time>[-k]` name, in
    `folder` (default: beside it); nothing is deleted. Returns the new path, or None when
    the file is gone (another process set it aside first)."""
    path = Path(path)
    try:
        is_dir = path.is_dir()
    except OSError:
        is_dir = False
    target = Path(folder) / path.name if folder is not None else path
    aside = reserve_aside_name(target, is_dir)
    try:
        os.replace(path, aside)
    except BaseException as exc:
        (aside.rmdir if is_dir else aside.unlink)()
        if isinstance(exc, FileNotFoundError):  # lost the race to another process
            return None
        raise
    return aside
