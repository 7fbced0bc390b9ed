"""Shared test setup: every test runs with the smoke preset and a private results folder."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(autouse=True)
def _isolated_results(tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "results"))
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    monkeypatch.setenv("ICIL_PRESET", "smoke")


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny models run fastest (and with steady timings) on one torch thread."""
    try:
        import torch
    except ImportError:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
