"""This machine: what is installed and where results come from.

- `envcheck.py`: `icil-paper env`, the packages, hardware and simulator checks (Vulkan too).
- `provenance.py`: the git commit, package versions and host every record carries.

The system packages `make setup` installs are the project's tool `tools/system_deps.py`.
Nothing is imported here, so each module loads only what it needs.
"""
