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
