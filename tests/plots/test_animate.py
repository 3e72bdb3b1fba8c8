"""Replay animations (offroadbench.plots.animate, offroadbench.io.animation): the footprint is drawn
where the telemetry puts it, the failure is marked at the end, and the file appears whole."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.animation import check_animation_path, save_animation
from offroadbench.plots.animate import (
    TrialView,
    footprint_corners,
    frame_indices,
    strip_series,
)

CELL = 0.05
HM = Heightmap(np.fromfunction(lambda r, c: 0.05 * np.sin(r / 9.0) * np.cos(c / 7.0), (161, 201)), CELL)
CLASSES = np.zeros(HM.shape, dtype=np.uint8)


def _telemetry(n: int = 61, rate_hz: float = 20.0) -> dict[str, np.ndarray]:
    """A vehicle driving along +x at 0.5 m/s from (2, 4), yawed along its path, z a parabola."""
    t = np.arange(n) / rate_hz
    x = 2.0 + 0.5 * t
    zeros = np.zeros(n)
    return {"t_s": t, "x_m": x, "y_m": 4.0 + zeros, "z_m": 0.3 + 0.5 * t**2, "yaw_rad": zeros,
            "roll_rad": zeros + math.radians(3.0), "pitch_rad": zeros - math.radians(2.0),
            "vx_m_s": 0.5 + zeros, "vy_m_s": zeros, "cmd_v_m_s": 0.5 + zeros}


def test_strip_series_units():
    s = strip_series(_telemetry())
    assert np.allclose(s["speed_m_s"], 0.5) and np.allclose(s["roll_deg"], 3.0) and np.allclose(s["pitch_deg"], -2.0)
    # z = 0.3 + 0.5 t^2 has a vertical acceleration of exactly 1 m/s^2 (the paper's second difference)
    assert np.isnan(s["az_m_s2"][[0, -1]]).all() and np.allclose(s["az_m_s2"][1:-1], 1.0)


def test_footprint_corners_turn_with_the_heading():
    c = footprint_corners(1.0, 2.0, math.pi / 2, 1.0, 0.6)  # facing +y
    assert np.allclose(c.mean(axis=0), [1.0, 2.0])
    assert np.allclose(c[0], [1.0 - 0.3, 2.5]) and np.allclose(c[3], [1.0 + 0.3, 2.5])  # the front edge is north


def test_frame_indices_end_on_the_last_sample_and_hold_it():
    idx = frame_indices(1000, 20.0, fps=10.0, max_frames=120, hold_s=1.5)
    assert len(idx) <= 120 and idx[0] == 0 and idx[-16:] == [999] * 16
    steps = np.diff(idx[:-15])
    assert steps.min() >= 2  # never slower than real time: 20 Hz samples at 10 fps
    assert frame_indices(0, 20.0) == []
    assert frame_indices(5, 20.0, fps=20.0, hold_s=0.0) == [0, 1, 2, 3, 4]


def test_view_draws_the_vehicle_where_it_is_and_marks_the_failure():
    tel = _telemetry()
    view = TrialView(HM, CLASSES, np.array([[2.0, 4.0], [8.0, 4.0]]), footprint_m=(0.99, 0.67), title="test")
    view.draw(tel, 30)
    img = view.to_rgb()
    assert img.dtype == np.uint8 and img.ndim == 3
    x, y = tel["x_m"][30], tel["y_m"][30]
    r, c = view.pixel_of(x, y)
    assert img[r - 1:r + 2, c - 1:c + 2].max() < 90  # the dark footprint
    assert np.allclose(np.asarray(view._body.get_xy())[:4].mean(axis=0), [x, y])
    ahead = view.pixel_of(x + 1.5, y)
    assert img[ahead].min() > 90  # the map, not the vehicle, 1.5 m ahead
    assert not view._fail_lines[0].get_visible() and view._fail_text.get_text() == ""
    view.draw(tel, failure_reason="stuck")
    assert view._fail_lines[0].get_visible() and view._fail_text.get_text() == "stuck at 3.0 s"
    assert view._fail_lines[0].get_xdata()[0] == pytest.approx(3.0)
    view.draw(tel, failure_reason="")
    assert not view._fail_lines[0].get_visible() and view._fail_text.get_text() == "success"


def test_gif_is_written_whole_with_one_frame_per_index(tmp_path):
    tel = _telemetry(21)
    view = TrialView(HM, CLASSES, np.array([[2.0, 4.0], [8.0, 4.0]]), footprint_m=(0.99, 0.67))
    out = tmp_path / "trial.gif"
    frames = [0, 10, 20]
    save_animation(view.fig, lambda i: view.draw(tel, i, failure_reason="tipped"), frames, out, fps=5)
    with Image.open(out) as im:
        assert im.n_frames == 3 and im.info["duration"] == 200
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trial.gif"]  # no temporary file left


def test_a_failing_frame_leaves_no_file(tmp_path):
    view = TrialView(HM, CLASSES, np.array([[2.0, 4.0], [8.0, 4.0]]), footprint_m=(0.99, 0.67))

    def draw(i):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        save_animation(view.fig, draw, [0], tmp_path / "trial.gif")
    assert list(tmp_path.iterdir()) == []


def test_animation_path_must_be_gif_or_mp4(tmp_path, monkeypatch):
    with pytest.raises(InputError, match=r"\.gif or \.mp4"):
        check_animation_path(tmp_path / "a.avi")
    monkeypatch.setattr("offroadbench.io.animation._ffmpeg", lambda: None)
    with pytest.raises(InputError, match="needs ffmpeg"):
        check_animation_path(tmp_path / "a.mp4")
    assert check_animation_path(tmp_path / "a.gif").suffix == ".gif"
