"""The reader's environment check: what `icil-paper env` and chapter 01 report.

Each simulator check runs in a subprocess with a time limit, so that a crashing native
library is a failed check rather than a crash of the caller.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
from dataclasses import asdict, dataclass

from icil_paper.setup.provenance import host_info, package_versions

MANUAL_FIX = (
    "ManiSkill needs a Vulkan device. On a machine without a GPU install Mesa's lavapipe "
    ">= 24.3, e.g. on Debian 12 as root: add the 'bookworm-backports' suite of your Debian "
    "mirror to apt, then `apt-get update && apt-get install -t bookworm-backports "
    "mesa-vulkan-drivers`; on Ubuntu 24.10+ `apt-get install mesa-vulkan-drivers`. "
    "With an NVIDIA GPU, install the driver's Vulkan ICD (libnvidia-gl)."
)

_VULKAN = """
import sapien
sapien.render.RenderSystem()
print("vulkan-ok")
"""


@functools.lru_cache(maxsize=1)
def vulkan_problem(python: str | None = None) -> str | None:
    """None when a Vulkan device works for SAPIEN, else a sentence naming the problem and fix."""
    try:
        out = subprocess.run([python or sys.executable, "-c", _VULKAN], capture_output=True,
                             text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"the Vulkan probe could not run ({exc}). {MANUAL_FIX}"
    if "vulkan-ok" in out.stdout:
        return None
    if "No module named 'sapien'" in out.stderr:
        return "SAPIEN is not installed (run `make setup`)."
    last = (out.stderr.strip().splitlines() or ["no output"])[-1]
    return f"no working Vulkan device ({last}). {MANUAL_FIX}"


@dataclass
class Check:
    """One capability check: did it work, how long it took, and what to do if it did not."""

    name: str
    ok: bool
    seconds: float
    detail: str


_ROBOSUITE = """
import numpy as np, robosuite
env = robosuite.make("Lift", robots="Panda", has_renderer=False, has_offscreen_renderer=False,
                     use_camera_obs=False, control_freq=20)
env.reset()
for _ in range(20):
    env.step(np.zeros(env.action_dim))
print(f"robosuite {robosuite.__version__}: Lift reset and 20 steps")
"""

_MANISKILL = """
import gymnasium as gym, mani_skill.envs, mani_skill
env = gym.make("PickCube-v1", obs_mode="state", control_mode="pd_ee_delta_pose",
               sim_backend="physx_cpu")
env.reset(seed=0)
for _ in range(20):
    env.step(env.action_space.sample())
print(f"mani_skill {mani_skill.__version__}: PickCube-v1 reset and 20 steps (physx_cpu)")
"""

_METAWORLD = """
import metaworld
from metaworld.env_dict import ALL_V3_ENVIRONMENTS_GOAL_OBSERVABLE as envs
env = envs["drawer-open-v3-goal-observable"](seed=0)
env.reset()
for _ in range(20):
    env.step(env.action_space.sample())
print("metaworld: drawer-open-v3 (goal observable) reset and 20 steps")
"""

_OFFSCREEN = """
import os
os.environ.setdefault("MUJOCO_GL", "egl")
import mujoco
model = mujoco.MjModel.from_xml_string(
    "<mujoco><worldbody><light pos='0 0 1'/><geom size='.1' rgba='1 0 0 1'/></worldbody></mujoco>")
renderer = mujoco.Renderer(model, 64, 64)
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer.update_scene(data)
image = renderer.render()
renderer.close()
assert image.shape == (64, 64, 3) and image.max() > 0, "blank image"
print(f"MuJoCo offscreen rendering with MUJOCO_GL={os.environ['MUJOCO_GL']}: 64x64 frame")
"""

_CHECKS = {  # name: (a script that exercises it, what to do when it fails)
    "metaworld": (_METAWORLD, "run `make setup` (it installs metaworld==3.1.1 with --no-deps "
                              "beside the pinned mujoco 3.3.7)"),
    "robosuite": (_ROBOSUITE, "run `make setup` (robosuite 1.5.2 needs mujoco 3.3.x, not 4.x)"),
    "maniskill": (_MANISKILL, "ManiSkill needs a Vulkan device: `make setup` installs Mesa's "
                              "lavapipe on Debian 12 as root; see `python -m tools.system_deps`"),
    "offscreen rendering": (_OFFSCREEN, "install an EGL driver (Debian: libegl1 libegl-mesa0) "
                                        "or set MUJOCO_GL=osmesa with libosmesa6"),
}


def _run_check(name: str, code: str, fix: str, timeout: float = 180) -> Check:
    start = time.perf_counter()
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return Check(name, False, timeout, f"timed out after {timeout:.0f} s; {fix}")
    seconds = time.perf_counter() - start
    if out.returncode == 0:
        return Check(name, True, seconds, out.stdout.strip().splitlines()[-1])
    last = (out.stderr.strip().splitlines() or ["no output"])[-1]
    return Check(name, False, seconds, f"{last[:300]}. Fix: {fix}")


def check_simulators() -> list[Check]:
    """Run the Meta-World, robosuite, ManiSkill and offscreen-rendering checks."""
    return [_run_check(name, code, fix) for name, (code, fix) in _CHECKS.items()]


def environment_report(preset: str, simulators: bool = True) -> dict:
    """Everything `icil-paper env` prints, as a dict, for the preset named `preset`."""
    report = {
        "preset": preset,
        "host": host_info(),
        "packages": package_versions(),
        "checks": [asdict(c) for c in check_simulators()] if simulators else [],
    }
    try:
        import torch

        report["torch"] = {"threads": torch.get_num_threads(),
                           "cuda": torch.cuda.is_available(),
                           "device": torch.cuda.get_device_name(0)
                           if torch.cuda.is_available() else "cpu"}
    except ImportError:
        report["torch"] = None
    return report


def format_report(report: dict) -> str:
    """A plain-text rendering of `environment_report()`."""
    host = report["host"]
    torch_info = report.get("torch") or {}
    lines = [
        f"preset     : {report['preset']} (set with --preset or ICIL_PRESET)",
        f"python     : {host['python']} on {host['platform']}",
        f"cpu        : {host['cpu_count']} cores",
        f"gpu        : {torch_info.get('device', 'torch not installed')}",
        "packages   :",
    ]
    lines += [f"  {name:<24} {version or 'NOT INSTALLED'}"
              for name, version in report["packages"].items()]
    if report["checks"]:
        lines.append("checks     :")
        for c in report["checks"]:
            status = "ok  " if c["ok"] else "FAIL"
            lines.append(f"  [{status}] {c['name']:<20} {c['seconds']:5.1f} s  {c['detail']}")
    return "\n".join(lines)
