"""This machine: what is installed and where results come from.

- `envcheck.py`: `icil-paper env`, the packages, hardware and simulator checks.
- `system_deps.py`: the system packages `make setup` installs (EGL, Vulkan, Chromium).
- `provenance.py`: the git commit, package versions and host every record carries.

Nothing is imported here, so each module loads only what it needs.
"""
