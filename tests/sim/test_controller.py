"""Pure pursuit, the ruckig speed profile and the skid-steer map, without physics."""


import numpy as np
import pytest

from offroadbench.sim import ControllerConfig, load_vehicle
from offroadbench.sim.trial.controller import LineTracker, PathTracker, SpeedProfile, pure_pursuit_omega
from offroadbench.sim.trial.skid_steer import achievable_twist, wheel_speeds


def test_pure_pursuit_curvature():
    # target 2 m ahead and 1 m left: alpha = atan(1/2), l = sqrt(5), kappa = 2 sin(alpha) / l = 2/5
    w = pure_pursuit_omega(np.zeros(2), 0.0, np.array([2.0, 1.0]), 1.0, 10.0)
    assert w == pytest.approx(0.4)
    assert pure_pursuit_omega(np.zeros(2), 0.0, np.array([2.0, -1.0]), 1.0, 10.0) == pytest.approx(-0.4)
    assert pure_pursuit_omega(np.zeros(2), 0.0, np.array([3.0, 0.0]), 1.0, 10.0) == 0.0
    assert pure_pursuit_omega(np.zeros(2), 0.0, np.array([0.0, 1.0]), 1.0, 0.5) == 0.5  # clipped


def _kinematic_run(profile: SpeedProfile, dt: float, steps: int):
    """Ideal tracking: the vehicle moves exactly at the commanded speed."""
    s = v = 0.0
    vs = []
    for _ in range(steps):
        v = profile.command(s, v)
        s += v * dt
        vs.append(v)
    return s, np.array(vs)


def test_speed_profile_reaches_cruise_is_jerk_limited_and_stops_at_goal():
    dt = 0.05
    prof = SpeedProfile(10.0, dt, v_max=1.0, a_max=3.0, j_max=4.0)
    s, v = _kinematic_run(prof, dt, 400)
    assert v.max() == pytest.approx(1.0, abs=1e-6)
    assert s == pytest.approx(10.0, abs=0.02)
    assert v[-1] == pytest.approx(0.0, abs=1e-6)
    acc = np.diff(np.concatenate([[0.0], v])) / dt
    jerk = np.diff(np.concatenate([[0.0], acc])) / dt
    assert np.abs(acc).max() <= 3.0 + 1e-6
    assert np.abs(jerk).max() <= 4.0 * 1.05  # discretised jerk within the limit
    # rising to 1 m/s jerk-limited takes 2 sqrt(v/j) = 1 s: ~10 m takes ~11 s
    t_end = dt * np.flatnonzero((v < 1e-6) & (np.arange(len(v)) > 10))[0]
    assert 10.5 < t_end < 12.5


def test_speed_profile_restarts_from_measured_speed():
    prof = SpeedProfile(10.0, 0.05, v_max=1.0, a_max=3.0, j_max=4.0)
    for _ in range(60):
        prof.command(2.0, 1.0)  # cruising
    # the vehicle is suddenly stopped by an obstacle: the command restarts near the measured 0
    assert prof.command(2.0, 0.0) < 0.2
    assert prof.command(10.5, 0.5) == 0.0  # past the goal: stop


def test_line_tracker_steers_back_to_the_line():
    spec = load_vehicle("husky")
    tr = LineTracker((0.0, 0.0), (20.0, 0.0), spec, ControllerConfig(lookahead_m=1.5))
    for _ in range(30):  # get up to speed
        v, w, s = tr.command(np.array([0.0, 0.5]), 0.0, np.array([1.0, 0.0]))
    assert s == 0.0 and v > 0.5
    assert w < 0  # left of the line: turn right
    v, w, _ = tr.command(np.array([2.0, -0.5]), 0.0, np.array([1.0, 0.0]))
    assert w > 0


def test_path_tracker_past_the_path_end_but_away_from_the_goal_keeps_driving():
    # an L-shaped path 10 m + 5 m: a vehicle that cut the corner and stands 2 m short of the goal on
    # the final leg's line projects onto the end of the path (progress = length) but is not there
    spec = load_vehicle("husky")
    tr = PathTracker([(0.0, 0.0), (10.0, 0.0), (10.0, 5.0)], spec, ControllerConfig())
    assert tr.length_m == pytest.approx(15.0)
    for _ in range(40):
        v, _, s = tr.command(np.array([10.0, 3.0]), np.pi / 2, np.array([0.0, 1.0]))
    assert v > 0.5  # still driving: 2 m to go
    v, _, _ = tr.command(np.array([10.0, 7.0]), np.pi / 2, np.array([0.0, 0.0]))  # overshot by 2 m
    assert v > 0.0  # told to drive back toward the goal, not that it has arrived
    v, _, _ = tr.command(np.array([10.0, 5.0]), np.pi / 2, np.array([0.0, 0.0]))
    assert v == 0.0  # at the goal


def test_skid_steer_wheel_speeds():
    spec = load_vehicle("husky")
    r = spec.wheel_radius_m
    left, right = wheel_speeds(1.0, 0.0, spec)
    assert left == right == pytest.approx(1.0 / r)
    left, right = wheel_speeds(0.0, 1.0, spec)  # turn in place, CCW
    half = 0.5 * 1.875 * spec.track_m
    assert left == pytest.approx(-half / r) and right == pytest.approx(half / r)


def test_wheel_speeds_saturate_at_the_top_speed_keeping_the_curvature():
    spec = load_vehicle("husky")
    r, half = spec.wheel_radius_m, 0.5 * spec.skid_track_factor * spec.track_m
    left, right = wheel_speeds(1.0, 0.5, spec)  # the outer side would need 1 + 0.5 * 0.535 m/s
    assert max(abs(left), abs(right)) * r == pytest.approx(spec.max_speed_m_s)
    assert (right - left) / (right + left) == pytest.approx(0.5 * half / 1.0)  # omega * half / v kept
    v, w = achievable_twist(1.0, 0.5, spec)
    assert w / v == pytest.approx(0.5) and v < 1.0
    left, right = wheel_speeds(0.0, 2.0, spec)  # in place: 2 * 0.535 = 1.07 m/s > 1 m/s at the tyres
    assert right * r == pytest.approx(spec.max_speed_m_s) and left == pytest.approx(-right)
    assert achievable_twist(0.0, 2.0, spec)[1] == pytest.approx(spec.max_speed_m_s / half)
    assert achievable_twist(0.5, 0.2, spec) == pytest.approx((0.5, 0.2))  # within the limit: unchanged
