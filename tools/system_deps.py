"""The system packages the simulators and the browser check need, checked and installed.

    python -m tools.system_deps             # report what works
    python -m tools.system_deps --install   # install what is missing (make setup runs this)

ManiSkill 3 (SAPIEN 3) needs a Vulkan device even for state observations; without a GPU,
Mesa's lavapipe >= 24.3 works. With `--install`, where the probe
(`icil_paper.setup.envcheck.vulkan_problem`) finds no device, on Debian 12 as root it adds
`bookworm-backports` to apt, deriving the mirror from the machine's own Debian source (no
host name is written into the repository), and installs `mesa-vulkan-drivers` from it. The
book's browser check (`tools/browser_check.py`) needs Chromium (`find_chromium`:
$ICIL_CHROMIUM, else the first candidate on PATH); `--install` installs Debian's `chromium`.
Anywhere else it prints what to install by hand and carries on: a missing system package
never stops setup (the tests that need it skip with the reason).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from icil_paper.setup.envcheck import MANUAL_FIX, vulkan_problem

BACKPORTS_SOURCE = Path("/etc/apt/sources.list.d/icil-paper-backports.sources")

MANUAL_CHROMIUM = (
    "The book's browser check needs Chromium: on Debian as root `apt-get install chromium`, "
    "on Ubuntu `apt-get install chromium-browser`; or set ICIL_CHROMIUM to a Chromium or "
    "Chrome executable."
)

CHROMIUM_CANDIDATES = ("chromium", "chromium-browser", "google-chrome")
"""Executables tried, in order, on PATH when $ICIL_CHROMIUM is not set."""


def debian_backports_entry(sources_dir: Path = Path("/etc/apt")) -> str | None:
    """A deb822 entry for bookworm-backports built from the machine's own Debian source.

    Reads the existing entries (deb822 `.sources` files or one-line `.list` files), takes the
    URI of the one that serves the `bookworm` suite, and returns the same mirror with suite
    `bookworm-backports`; None when no Debian 12 source is found.
    """
    candidates = sorted(sources_dir.glob("sources.list.d/*.sources"))
    for path in candidates:
        for stanza in re.split(r"\n\s*\n", path.read_text()):
            fields = {}
            for line in stanza.splitlines():
                if ":" in line and not line.lstrip().startswith("#"):
                    key, _, value = line.partition(":")
                    fields[key.strip().lower()] = value.strip()
            if "bookworm" in fields.get("suites", "").split() and fields.get("uris"):
                signed = fields.get("signed-by", "/usr/share/keyrings/debian-archive-keyring.gpg")
                return (f"Types: deb\nURIs: {fields['uris'].split()[0]}\n"
                        f"Suites: bookworm-backports\nComponents: main\nSigned-By: {signed}\n")
    lists = [sources_dir / "sources.list", *sorted(sources_dir.glob("sources.list.d/*.list"))]
    for path in lists:
        if not path.exists():
            continue
        for line in path.read_text().splitlines():
            parts = line.split()
            if len(parts) >= 3 and parts[0] == "deb" and "bookworm" in parts[2:3]:
                uri = next(p for p in parts[1:] if "://" in p)
                return (f"Types: deb\nURIs: {uri}\nSuites: bookworm-backports\n"
                        "Components: main\n"
                        "Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n")
    return None


def apt_get_problem() -> str | None:
    """None where apt-get can install packages here, else why it cannot."""
    if sys.platform != "linux":
        return f"not Linux ({sys.platform})"
    if os.geteuid() != 0:
        return "not root"
    if shutil.which("apt-get") is None:
        return "no apt-get (not a Debian-like system)"
    return None


def apt_get_install(*args: str) -> str | None:
    """`apt-get update`, then `apt-get install -y ARGS`, printing each command; None on
    success, else which command failed."""
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", *args]):
        print("+", " ".join(cmd), flush=True)
        if subprocess.run(cmd, env=env).returncode != 0:
            return f"`{' '.join(cmd)}` failed"
    return None


def install_lavapipe() -> str | None:
    """Install lavapipe from bookworm-backports; None on success, else why it could not."""
    problem = apt_get_problem()
    if problem:
        return problem
    entry = debian_backports_entry()
    if entry is None:
        return "no Debian 12 (bookworm) apt source found to derive the backports mirror from"
    if not BACKPORTS_SOURCE.exists() or BACKPORTS_SOURCE.read_text() != entry:
        BACKPORTS_SOURCE.write_text(entry)
    return apt_get_install("-t", "bookworm-backports", "mesa-vulkan-drivers", "libvulkan1")


def ensure_vulkan(install: bool) -> None:
    """Report whether a Vulkan device works; with `install`, install lavapipe if not."""
    problem = vulkan_problem()
    if problem is None:
        print("system: Vulkan device works (ManiSkill can run)")
        return
    print(f"system: {problem}")
    if not install:
        return
    why_not = install_lavapipe()
    vulkan_problem.cache_clear()
    problem = vulkan_problem()
    if problem is None:
        print("system: installed Mesa lavapipe; Vulkan device works (ManiSkill can run)")
    else:
        reason = f" ({why_not})" if why_not else ""
        print(f"system: could not install lavapipe automatically{reason}.\n"
              f"  Install by hand: {MANUAL_FIX}\n"
              "  Everything else works; ManiSkill tests will be skipped with this reason.")


def find_chromium() -> str | None:
    """The Chromium executable: $ICIL_CHROMIUM, else the first of CHROMIUM_CANDIDATES on PATH.
    The book's browser check launches the one found here."""
    explicit = os.environ.get("ICIL_CHROMIUM")
    if explicit:
        return explicit if Path(explicit).is_file() else None
    for name in CHROMIUM_CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


def chromium_problem() -> str | None:
    """None when a Chromium executable is found (`find_chromium`)."""
    return None if find_chromium() else f"Chromium not found. {MANUAL_CHROMIUM}"


def install_chromium() -> str | None:
    """Install Debian's chromium with apt-get; None on success, else why it could not."""
    return apt_get_problem() or apt_get_install("chromium")


def ensure_chromium(install: bool) -> None:
    """Report whether Chromium is there; with `install`, install it where it is missing."""
    problem = chromium_problem()
    if problem is None:
        print("system: Chromium found (the book's browser check can run)")
        return
    print(f"system: {problem}")
    if not install:
        return
    why_not = install_chromium()
    if chromium_problem() is None:
        print("system: installed Debian's chromium (the book's browser check can run)")
    else:
        reason = f" ({why_not})" if why_not else ""
        print(f"system: could not install Chromium automatically{reason}.\n"
              f"  Install by hand: {MANUAL_CHROMIUM}\n"
              "  Everything else works; the browser check and its tests say what is missing.")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.system_deps",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--install", action="store_true",
                        help="install what is missing: lavapipe (root, Debian 12), chromium "
                             "(root, apt-get)")
    args = parser.parse_args(argv)
    ensure_chromium(args.install)
    ensure_vulkan(args.install)
    return 0  # a missing system library never stops setup: the rest of the project works


if __name__ == "__main__":
    sys.exit(main())
