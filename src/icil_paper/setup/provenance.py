"""What a result needs to be traced back: git commit, package versions, host."""

from __future__ import annotations

import functools
import os
import platform
import socket
import subprocess
from importlib import metadata
from pathlib import Path

KEY_PACKAGES = (
    "torch", "numpy", "scipy", "mujoco", "robosuite", "mani-skill", "sapien", "gymnasium",
    "h5py", "tokenizers", "vector-quantize-pytorch", "rerun-sdk", "jupyter-book",
    "scikit-learn", "matplotlib",
)

REPO_ROOT = Path(__file__).resolve().parents[3]


def package_versions(names: tuple[str, ...] = KEY_PACKAGES) -> dict[str, str | None]:
    """Installed version of each package, or None (looked up once per process)."""
    return {name: _version(name) for name in names}


@functools.cache
def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


@functools.lru_cache(maxsize=1)
def git_state() -> dict[str, str | bool | None]:
    """The checkout's commit, and whether tracked files outside `results/` have changes."""
    def git(*args: str) -> str | None:
        try:
            out = subprocess.run(["git", "-C", str(REPO_ROOT), *args], capture_output=True,
                                 text=True, timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return out.stdout.strip() if out.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    status = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results")
    return {"commit": commit, "dirty": bool(status) if status is not None else None}


def host_info() -> dict[str, str | int | None]:
    """Host name, platform, CPU count and the GPU torch sees (if any)."""
    info: dict[str, str | int | None] = {
        "hostname": socket.gethostname(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "gpu": None,
    }
    try:
        import torch

        if torch.cuda.is_available():
            info["gpu"] = torch.cuda.get_device_name(0)
    except ImportError:
        pass
    return info
