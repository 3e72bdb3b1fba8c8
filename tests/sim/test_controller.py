"""Pure pursuit, the ruckig speed profile and the skid-steer map, without physics."""


import numpy as np
import pytest

from offroadbench.errors import InputError

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


def _kinematic_run(profile: SpeedProfile, dt: float, steps: int, slip: float = 0.0):
    """The vehicle moves at ``(1 - slip)`` of the commanded wheel speed (ideal tracking at slip 0).
    (progress, commands, ground speeds)."""
    s = v = 0.0
    us, vs = [], []
    for _ in range(steps):
        u = profile.command(s, v)
        v = (1.0 - slip) * u
        s += v * dt
        us.append(u)
        vs.append(v)
    return s, np.array(us), np.array(vs)


def test_speed_profile_reaches_cruise_is_jerk_limited_and_stops_at_goal():
    dt = 0.05
    prof = SpeedProfile(10.0, dt, v_max=1.0, a_max=3.0, j_max=4.0)
    s, v, _ = _kinematic_run(prof, dt, 400)
    assert v.max() == pytest.approx(1.0, abs=1e-6)
    assert s == pytest.approx(10.0, abs=0.02)
    assert v[-1] == pytest.approx(0.0, abs=1e-6)
    ref_v = []  # the reference itself is jerk-limited (the feedback adds only a small correction)
    prof = SpeedProfile(10.0, dt, v_max=1.0, a_max=3.0, j_max=4.0)
    for _ in range(400):
        prof.command(prof.reference[0], prof.reference[1])  # a vehicle exactly on the reference
        ref_v.append(prof.reference[1])
    acc = np.diff(np.concatenate([[0.0], ref_v])) / dt
    jerk = np.diff(np.concatenate([[0.0], acc])) / dt
    assert np.abs(acc).max() <= 3.0 + 1e-6
    assert np.abs(jerk).max() <= 4.0 * 1.05  # discretised jerk within the limit
    # rising to 1 m/s jerk-limited takes 2 sqrt(v/j) = 1 s: ~10 m takes ~11 s
    t_end = dt * np.flatnonzero((v < 1e-6) & (np.arange(len(v)) > 10))[0]
    assert 10.5 < t_end < 12.5


@pytest.mark.parametrize("slip", [0.2, 0.4])
def test_under_steady_slip_the_ground_speed_reaches_the_reference(slip):
    """Wheel-speed headroom (top speed 2 m/s, cruise 1 m/s): the feedback raises the command to
    v_ref / (1 - s), so the ground speed reaches 1 m/s within 2 % and the vehicle stops at the goal;
    the old re-plan-from-measurement loop settled near a dt / s instead."""
    dt = 0.05
    prof = SpeedProfile(30.0, dt, v_max=1.0, a_max=3.0, j_max=4.0, command_max_m_s=2.0)
    s, u, v = _kinematic_run(prof, dt, 1000, slip=slip)
    assert v.max() < 1.1  # the lag of the start is made up by a small overshoot (7.6 % at slip 0.4)
    cruise = v[400:500]  # 20-25 s, 5-10 m before the goal
    assert np.all(np.abs(cruise - 1.0) <= 0.02), (cruise.min(), cruise.max())
    assert u[400:500].mean() == pytest.approx(1.0 / (1.0 - slip), rel=0.02)
    assert s == pytest.approx(30.0, abs=0.05) and u[-1] == 0.0


def test_without_headroom_the_command_holds_the_top_speed_and_does_not_wind_up():
    """Top speed = cruise: under slip 0.3 the command sits at the top speed (never collapses towards
    the measured 0.7 m/s), the lag stays within the re-plan bound, and the integral stays bounded."""
    dt = 0.05
    prof = SpeedProfile(30.0, dt, v_max=1.0, a_max=3.0, j_max=4.0, command_max_m_s=1.0, lag_bound_m=0.5)
    s = v = 0.0
    for k in range(400):
        u = prof.command(s, v)
        v = 0.7 * u
        s += v * dt
        if k > 40:
            assert u == pytest.approx(1.0)
            assert prof.reference[0] - s <= 0.5 + 1e-9
    assert prof.replans > 0 and 0.0 <= prof.integral_m_s <= 1.0


def test_a_stalled_vehicle_keeps_its_command_and_is_not_reset_to_its_measured_speed():
    prof = SpeedProfile(10.0, 0.05, v_max=1.0, a_max=3.0, j_max=4.0, command_max_m_s=1.5)
    s = 0.0
    for _ in range(60):
        s += 0.05 * prof.command(s, 1.0 if s > 0.5 else 0.5)
    u = [prof.command(s, 0.0) for _ in range(100)]  # held by an obstacle for 5 s
    assert min(u) >= 1.0  # v_ref + k_p * bound: the wheels keep turning
    assert max(u) <= 1.5 and prof.integral_m_s <= 1.5  # saturated, no windup beyond the limit
    assert prof.command(10.5, 0.5) == 0.0  # past the goal: stop


def test_traction_control_caps_the_command_at_the_slip_limit():
    prof = SpeedProfile(20.0, 0.05, v_max=1.0, a_max=3.0, j_max=4.0, command_max_m_s=2.0, slip_limit=0.25)
    for _ in range(40):
        prof.command(0.0, 0.0)
    assert prof.command(0.0, 0.0) == pytest.approx(0.1 / 0.75)  # creep speed / (1 - limit)
    assert prof.command(0.0, 0.6) == pytest.approx(0.6 / 0.75)


def test_speed_loop_settings_are_checked():
    with pytest.raises(InputError, match="traction_slip_limit"):
        ControllerConfig(traction_slip_limit=1.0)
    with pytest.raises(InputError, match="speed_lag_bound_m"):
        ControllerConfig(speed_lag_bound_m=0.0)


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
