"""System checks for the simulators' rendering: Vulkan (ManiSkill / SAPIEN) and EGL (MuJoCo).

ManiSkill 3 needs a Vulkan device even for state observations (without a GPU: Mesa's
lavapipe, 24.3 or newer); `make_env("maniskill/...")` raises `RenderingUnavailable` naming
the fix instead of SAPIEN's bare error.
"""

from __future__ import annotations

import functools

from icil_paper.setup.envcheck import MANUAL_FIX
from icil_paper.setup.envcheck import vulkan_problem as probe

LAVAPIPE_HOWTO = (
    "ManiSkill (SAPIEN 3) needs a Vulkan device, even for state observations. With an NVIDIA "
    "GPU install the driver's Vulkan ICD (libnvidia-gl). Without a GPU install Mesa's software "
    "driver lavapipe, version 24.3 or newer (SAPIEN needs VK_KHR_external_semaphore_fd): on "
    "Debian 12 as root, `make setup` does it (python -m tools.system_deps --install), or by "
    "hand: add the 'bookworm-backports' suite of your Debian mirror to apt, then `apt-get update "
    "&& apt-get install -t bookworm-backports mesa-vulkan-drivers`; on Ubuntu 24.10 or newer "
    "`apt-get install mesa-vulkan-drivers`. Check with `vulkaninfo --summary` (package "
    "vulkan-tools) that a device named 'llvmpipe' is listed."
)


class RenderingUnavailable(RuntimeError):
    """The simulator cannot start because the machine lacks a rendering device."""


@functools.lru_cache(maxsize=1)
def vulkan_problem() -> str | None:
    """None when SAPIEN finds a Vulkan device, else the problem and the fix (probed once)."""
    problem = probe()
    if problem is None:
        return None
    return f"{problem.replace(MANUAL_FIX, '').strip()} {LAVAPIPE_HOWTO}"


def vulkan_available() -> bool:
    """Whether ManiSkill can start on this machine."""
    return vulkan_problem() is None


def vulkan_skip_reason() -> str:
    """The reason ManiSkill tests give when they skip ('' when Vulkan works)."""
    problem = vulkan_problem()
    return "" if problem is None else f"ManiSkill cannot start: {problem}"

