"""Latent trajectory views and their rerun recordings (chapters 01 and 04)."""

from __future__ import annotations

import numpy as np
import pytest

from icil_paper.viz.recording import principal_view, record_latent_trajectories


def test_principal_view_finds_the_direction_of_motion_and_pads_narrow_latents():
    rng = np.random.default_rng(0)
    direction = rng.normal(size=16)
    t = np.linspace(-1, 1, 30)[:, None]
    z = t * direction + 5.0  # a line in 16-D, off the origin
    view = principal_view(z)
    assert view.shape == (30, 3)
    np.testing.assert_allclose(np.abs(view[:, 0]), np.abs(t[:, 0]) * np.linalg.norm(direction),
                               rtol=1e-6)
    np.testing.assert_allclose(view[:, 1:], 0.0, atol=1e-9)
    narrow = principal_view(rng.normal(size=(10, 2)))  # D = 2 < 3: zero-padded
    assert narrow.shape == (10, 3) and np.all(narrow[:, 2] == 0)
    with pytest.raises(ValueError, match=r"\(T, D\)"):
        principal_view(np.zeros(5))


def test_latent_recording_holds_every_label_and_a_picture(tmp_path):
    rr = pytest.importorskip("rerun")
    rng = np.random.default_rng(1)
    actions = rng.normal(size=(12, 7))
    views = {"vq": principal_view(rng.normal(size=(12, 8))),
             "lipvq": principal_view(rng.normal(size=(12, 8)), dims=2)}
    out = record_latent_trajectories(tmp_path / "lat" / "z.rrd", actions, views, title="t")
    assert out["png"].read_bytes()[:4] == b"\x89PNG"
    assert out["rrd"] is not None, "rerun is installed, so the recording must be written"
    entities = {c.entity_path for c in
                rr.dataframe.load_recording(str(out["rrd"])).schema().component_columns()}
    for label in views:
        assert {f"/latents/{label}/path", f"/latents/{label}/now"} <= entities
    assert "/actions/gripper" in entities
    assert not list(tmp_path.glob("lat/.*.tmp"))  # the temporary file became the recording


def test_latent_recording_rejects_bad_views(tmp_path):
    actions = np.zeros((10, 7))
    with pytest.raises(ValueError, match="'bad'.*T=10"):
        record_latent_trajectories(tmp_path / "a.rrd", actions, {"bad": np.zeros((9, 3))})
    with pytest.raises(ValueError, match="empty"):
        record_latent_trajectories(tmp_path / "b.rrd", actions, {})
    assert not list(tmp_path.iterdir())  # nothing half-written


def test_failed_recording_leaves_only_the_picture(tmp_path, monkeypatch):
    pytest.importorskip("rerun")
    import icil_paper.viz.recording as recording

    def fail_midway(path, *args):
        with recording._rrd_stream(path):
            raise RuntimeError("disk full")

    monkeypatch.setattr(recording, "_write_latent_rrd", fail_midway)
    with pytest.warns(UserWarning, match="disk full"):
        out = record_latent_trajectories(tmp_path / "z.rrd", np.zeros((5, 7)),
                                         {"a": np.ones((5, 3)) * np.arange(5)[:, None]})
    assert out["rrd"] is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z.png"]  # no .rrd, no temporary
