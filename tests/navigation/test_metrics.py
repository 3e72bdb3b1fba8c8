"""Metric functions on synthetic telemetry with known answers (Majhor & Bos 2023, Sec. 2.4, Eq. 5)."""

import math

import numpy as np
import pytest

from offroadbench.navigation import metrics

DT = 0.05  # the paper's 20 Hz


def test_sine_height_has_known_rms_vertical_acceleration():
    # z = A sin(2 pi f t): a = -A (2 pi f)^2 sin(...), RMS = A (2 pi f)^2 / sqrt(2)
    amp, f = 0.03, 1.0
    t = np.arange(0, 200, DT)
    z = 0.5 + amp * np.sin(2 * np.pi * f * t)
    expected = amp * (2 * np.pi * f) ** 2 / math.sqrt(2)
    # the second difference sees (sin(pi f dt) / (pi f dt))^2 of the true amplitude
    factor = (math.sin(math.pi * f * DT) / (math.pi * f * DT)) ** 2
    assert metrics.rms_vertical_acceleration(z, DT) == pytest.approx(expected * factor, rel=1e-3)
    assert metrics.rms_vertical_acceleration(z, DT) == pytest.approx(expected, rel=0.01)


def test_constant_slope_and_parabola():
    t = np.arange(0, 10, DT)
    assert metrics.rms_vertical_acceleration(0.3 * t + 1.0, DT) == pytest.approx(0.0, abs=1e-9)
    # free fall: a = -9.81 exactly under the second difference
    assert metrics.rms_vertical_acceleration(-0.5 * 9.81 * t**2, DT) == pytest.approx(9.81, rel=1e-9)


def test_angle_rate_of_a_ramp_in_degrees():
    t = np.arange(0, 5, DT)
    pitch = np.radians(10.0) * t  # 10 deg/s
    assert metrics.rms_angle_rate_deg_s(pitch, DT) == pytest.approx(10.0, rel=1e-9)


def test_roll_is_unwrapped_before_differentiating():
    # rolling steadily through +-180 deg at 90 deg/s: the wrapped series jumps by 360 deg
    t = np.arange(0, 8, DT)
    wrapped = np.angle(np.exp(1j * np.radians(90.0) * t))
    assert np.abs(np.diff(wrapped)).max() > np.pi  # the test signal does wrap
    assert metrics.rms_angle_rate_deg_s(wrapped, DT) == pytest.approx(90.0, rel=1e-9)


def _quat_from_axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.array([*(axis * math.sin(angle / 2)), math.cos(angle / 2)])


def _quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ])


def test_roll_pitch_yaw_from_level_reference():
    yaw, pitch_up, roll = math.radians(130), math.radians(20), math.radians(-35)
    # body = yaw about z, then nose up (negative rotation about body y), then roll about body x
    q = _quat_mul(_quat_mul(_quat_from_axis_angle([0, 0, 1], yaw), _quat_from_axis_angle([0, 1, 0], -pitch_up)),
                  _quat_from_axis_angle([1, 0, 0], roll))
    r, p, y = metrics.roll_pitch_yaw_from_quat(q)
    assert (float(r), float(p), float(y)) == pytest.approx((roll, pitch_up, yaw), abs=1e-12)
    # a vehicle on its side has |roll| = 90 deg and no pitch, whatever its heading
    side = _quat_mul(_quat_from_axis_angle([0, 0, 1], 1.0), _quat_from_axis_angle([1, 0, 0], math.pi / 2))
    r, p, _ = metrics.roll_pitch_yaw_from_quat(side)
    assert math.degrees(abs(float(r))) == pytest.approx(90.0) and abs(float(p)) < 1e-12
    # vectorised over a batch
    r, p, y = metrics.roll_pitch_yaw_from_quat(np.stack([q, side]))
    assert r.shape == (2,)


def test_path_length_success_rate_and_stuck():
    square = np.array([[0, 0], [3, 0], [3, 4], [0, 4]], float)
    assert metrics.path_length(square) == pytest.approx(10.0)
    assert metrics.path_length(square[:1]) == 0.0
    assert metrics.success_rate([True, False, True, True]) == 75.0  # Eq. 5
    assert math.isnan(metrics.success_rate([]))
    # moves 1 cm per sample for 10 samples, then stands still
    xy = np.zeros((40, 2))
    xy[:10, 0] = np.arange(10) * 0.01
    xy[10:, 0] = 0.09
    assert metrics.stuck_index(xy, window=20, distance_m=0.2) == 20  # within 0.2 m over the first window
    assert metrics.stuck_index(xy * 100, window=20, distance_m=0.2) == 29  # 1 m steps: stuck once still
    moving = np.column_stack([np.arange(100) * 0.05, np.zeros(100)])
    assert metrics.stuck_index(moving, window=20, distance_m=0.2) is None


def test_soil_statistics_over_moving_samples_ignore_rest_and_spikes():
    from offroadbench.navigation.metrics import mean_where, moving_samples, percentile, sinkage_summary

    n = 200
    cmd = np.r_[np.zeros(10), np.full(n - 20, 1.0), np.zeros(10)]  # at rest, driven, stopped at the goal
    vx = np.r_[np.zeros(10), np.full(n - 20, 0.8), np.zeros(10)]
    moving = moving_samples(cmd, vx, np.zeros(n))
    assert moving.sum() == n - 20
    assert moving_samples([1.0], [0.0], [0.0])[0]  # wheels spinning in place: driven, so counted
    sink = np.where(moving, 0.014, 0.009)
    sink[50] = 0.037  # one spike (a wheel landing after a bump)
    median, p95 = sinkage_summary(sink, moving)
    assert median == pytest.approx(0.014) and p95 == pytest.approx(0.014)
    slip = np.where(moving, 0.2, 0.0)
    assert mean_where(slip, moving) == pytest.approx(0.2)
    assert math.isnan(mean_where(slip, np.zeros(n, dtype=bool)))
    x = np.random.default_rng(0).normal(size=33)
    for q in (0.0, 5.0, 50.0, 95.0, 100.0):
        assert percentile(x, q) == pytest.approx(float(np.percentile(x, q)), abs=1e-15)
