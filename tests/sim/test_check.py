"""The vehicle check (offroadbench.sim.check) on both shipped vehicles: the figures the issue asks
for, each against its physical or geometric expectation."""

from __future__ import annotations

import math

import pytest

from offroadbench.sim.check import check_vehicle, climb_limit_deg


@pytest.fixture(scope="module", params=["husky", "jackal"])
def checked(request):
    return request.param, check_vehicle(request.param)


def _rows(rows, prefix):
    out = [r for r in rows if r.name.startswith(prefix)]
    assert out, prefix
    return out


def test_yaw_rate_follows_the_command_at_every_heading(checked):
    name, rows = checked
    yaw = _rows(rows, "yaw rate")
    assert len(yaw) == 2 * 3 * 4  # in place and at cruise, 3 headings, 4 commands
    for r in yaw:
        assert r.ok and 0.85 <= r.measured / r.expected <= 1.1, (name, r)


def test_tilt_table_tip_angle_is_the_geometric_one(checked):
    name, rows = checked
    (tip,) = _rows(rows, "static tip angle")
    assert tip.ok and abs(tip.measured - tip.expected) <= 2.0
    assert 50.0 < tip.expected < 60.0  # atan((track/2) / h) of low-slung vehicles


def test_drift_stopping_side_slope_climb_and_step_are_within_tolerance(checked):
    name, rows = checked
    for prefix in ("straight-line drift", "stopping distance", "side slope held, parked",
                   "steepest grade climbed from rest", "highest step climbed"):
        for r in _rows(rows, prefix):
            assert r.ok, (name, r)


def test_spec_sheet_figures_stand_beside_the_measured_ones(checked):
    name, rows = checked
    spec_rows = [r for r in rows if "spec sheet" in r.name]
    if name == "husky":
        # Clearpath's sheet: 45 deg climb, 30 deg side slope; the side slope is held, the climb
        # falls short and the row says why
        side = next(r for r in spec_rows if r.name.startswith("side slope"))
        assert side.expected == 30.0 and side.ok
        climb = next(r for r in spec_rows if r.name.startswith("steepest grade"))
        assert climb.expected == 45.0
        assert climb.ok or "short of the sheet" in climb.note
    else:
        assert spec_rows == []  # the Jackal's sheet gives no slope figures


def test_results_are_plain_json_rows(checked):
    _, rows = checked
    for r in rows:
        d = r.as_dict()
        assert {"name", "measured", "expected", "unit", "ok"} <= set(d)
        assert isinstance(d["ok"], bool) and math.isfinite(d["measured"])


def test_soft_soil_rows_show_sinkage_and_a_lower_climb_than_rigid_ground(checked):
    name, rows = checked
    soft = _rows(rows, "soft soil")
    assert len(soft) == 3 and all(r.ok for r in soft), (name, soft)
    sink = next(r for r in soft if "sinkage" in r.name)
    assert 0.001 < sink.measured < 0.05  # mm to cm under the vehicle's load, lunar gravity
    soft_climb = next(r for r in soft if "grade" in r.name).measured
    rigid_climb = next(r for r in rows if r.name == "steepest grade climbed from rest").measured
    assert soft_climb < rigid_climb - 5.0, (name, soft_climb, rigid_climb)


def test_climb_limit_formula():
    # no load transfer (h = 0) and strong motors: the grip limit atan(mu)
    assert climb_limit_deg(50.0, 0.0, 0.25, 2, 0.15, 1e6, 0.8) == pytest.approx(math.degrees(math.atan(0.8)), abs=1e-6)
    # grip without limit: the motors, asin(n tau / (r m g))
    assert climb_limit_deg(50.0, 0.0, 0.25, 2, 0.15, 10.0, 100.0) == pytest.approx(
        math.degrees(math.asin(4 * 10.0 / (0.15 * 50.0 * 9.81))), abs=1e-6)
    # load transfer only lowers it when an axle is torque-limited
    assert climb_limit_deg(50.0, 0.2, 0.25, 2, 0.15, 15.0, 0.8) < climb_limit_deg(50.0, 0.0, 0.25, 2, 0.15, 15.0, 0.8)


def test_step_bound_geometry():
    from offroadbench.sim.check import step_bound_m

    assert step_bound_m(0.165, 0.13, 0.512, overhang=True) == 0.13  # the nose strikes first
    assert step_bound_m(0.1, 0.3, 0.5, overhang=False) == pytest.approx(0.1, abs=1e-3)  # high belly: the radius
    low = step_bound_m(0.1, 0.02, 0.5, overhang=False)  # low belly, long wheelbase: the belly hangs up
    d = math.sqrt(2 * 0.1 * low - low**2)
    assert 0.02 < low < 0.1 and 0.02 + low * d / 0.5 == pytest.approx(low, abs=1e-3)
