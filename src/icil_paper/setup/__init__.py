"""This machine: what is installed (`envcheck.py`, `icil-paper env`) and where results come
from (`provenance.py`: git commit, package versions, host).

Nothing is imported here, so each module loads only what it needs.
"""
