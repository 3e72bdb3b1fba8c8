"""The vehicle check (offroadbench.sim.rigs.vehicle_check): both shipped vehicles pass against their own physics,
spec-sheet figures stand beside as information, and broken vehicles fail the row that shows it."""

from __future__ import annotations

import math

import pytest

from offroadbench.sim.rigs.vehicle_check import check_vehicle, climb_limit_deg


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
    _name, rows = checked
    (tip,) = _rows(rows, "static tip angle")
    assert tip.ok and abs(tip.measured - tip.expected) <= 2.0
    assert 50.0 < tip.expected < 60.0  # atan((track/2) / h) of low-slung vehicles


def test_drift_stopping_side_slope_climb_and_step_are_within_tolerance(checked):
    name, rows = checked
    for prefix in ("straight-line drift", "stopping distance", "side slope held, parked",
                   "steepest grade climbed from rest", "highest step climbed"):
        for r in _rows(rows, prefix):
            assert r.ok, (name, r)


def test_every_row_passes_for_the_shipped_vehicles(checked):
    """`vehicle check husky|jackal` exits 0: each shipped model agrees with its own physics."""
    name, rows = checked
    assert [r.name for r in rows if not r.ok] == [], name


def test_spec_sheet_figures_stand_beside_as_information(checked):
    name, rows = checked
    sheet = {r.name: r for r in rows if r.sheet is not None}
    if name == "husky":
        # Clearpath's sheet: 45 deg climb, 30 deg side slope. The climb row is judged against the
        # grip limit of the model's tyres (mu 0.8: atan(0.8) = 38.7 deg), the sheet's 45 deg stands
        # beside it with the reason for the difference
        climb = sheet["steepest grade climbed from rest"]
        assert climb.sheet == 45.0 and climb.ok
        assert climb.expected == pytest.approx(math.degrees(math.atan(0.8)), abs=0.5)
        assert "needs mu >= 1.00" in climb.note
        side = sheet["side slope held, parked"]
        assert side.sheet == 30.0 and side.ok and "within this model's limit" in side.note
    else:
        assert sheet == {}  # the Jackal's sheet gives no slope figures


def _broken(spec, tmp_path, *, friction=None, com_raise_m=0.0):
    """A copy of ``spec`` with other wheel friction, or with the chassis' centre of mass raised."""
    import dataclasses
    import re
    from pathlib import Path

    if friction is not None:
        spec = dataclasses.replace(spec, wheel_friction=friction)
    if com_raise_m:
        text = Path(spec.urdf).read_text()
        base = re.search(r'<link name="base_link">.*?<origin xyz="([^"]+)"', text, re.DOTALL)
        x, y, z = map(float, base.group(1).split())
        text = text[: base.start(1)] + f"{x:g} {y:g} {z + com_raise_m:g}" + text[base.end(1):]
        urdf = tmp_path / "raised.urdf"
        urdf.write_text(text)
        spec = dataclasses.replace(spec, urdf=str(urdf))
    return spec


def _quick_check(spec):
    return {r.name: r for r in check_vehicle(spec, headings_deg=(0.0,), yaw_commands_rad_s=(0.5,))}


def test_slippery_tyres_fail_the_turning_rows_not_the_grip_limited_ones(tmp_path):
    """Wheel friction 0.1: the climb and the parked side slope are judged against atan(0.1) and
    pass; the vehicle can no longer turn as it is commanded (the kinematic yaw rate at 1 m/s needs
    only 0.4 m/s^2 of the 1 m/s^2 its grip gives), so the turning row fails."""
    from offroadbench.sim.trial.vehicle import load_vehicle

    rows = _quick_check(_broken(load_vehicle("husky"), tmp_path, friction=0.1))
    grip = math.degrees(math.atan(0.1))
    climb = rows["steepest grade climbed from rest"]
    assert climb.expected == pytest.approx(grip, abs=0.1) and climb.ok
    assert rows["side slope held, parked"].ok and rows["side slope held, parked"].expected == pytest.approx(grip)
    assert not rows["yaw rate at 1 m/s, heading 0 deg, command 0.5 rad/s"].ok
    assert rows["static stability: tip angle over slide angle"].ok


def test_raised_centre_of_mass_fails_the_stability_row(tmp_path):
    """The Husky's chassis centre of mass 0.5 m higher: it would roll over at about 26 deg, before its
    tyres slide at 38.7 deg. The stability row fails; the tilt table still finds the tip angle the
    geometry gives for the raised centre of mass."""
    from offroadbench.sim.trial.vehicle import load_vehicle

    rows = _quick_check(_broken(load_vehicle("husky"), tmp_path, com_raise_m=0.5))
    stability = rows["static stability: tip angle over slide angle"]
    assert not stability.ok and stability.measured < 30.0 < stability.expected
    tip = rows["static tip angle (tilt table)"]
    assert tip.expected < 30.0 and abs(tip.measured - tip.expected) < 3.0
    climb = rows["steepest grade climbed from rest"]
    assert climb.expected < 25.0  # the pitch-over angle atan(a / h) caps the climb


def test_a_step_attempt_ends_when_the_vehicle_turns_over(tmp_path, monkeypatch):
    """The Husky with its centre of mass 0.5 m higher goes over backwards at a 0.1 m step: the attempt
    is not a climb, and it ends there (about 3 s in), not after the 10 s an attempt may take."""
    import contextlib
    import dataclasses

    from offroadbench.sim import SimConfig
    from offroadbench.sim.rigs import vehicle_check
    from offroadbench.sim.trial.vehicle import load_vehicle

    steps = []
    real_open = vehicle_check.open_world

    @contextlib.contextmanager
    def counted(*args, **kwargs):
        with real_open(*args, **kwargs) as world:
            real = world.step
            world.step = lambda: (steps.append(1), real())[1]
            yield world

    monkeypatch.setattr(vehicle_check, "open_world", counted)
    sim = dataclasses.replace(SimConfig(), settle_time_s=0.5)
    spec = _broken(load_vehicle("husky"), tmp_path, com_raise_m=0.5)
    assert not vehicle_check._climbs_step(spec, sim, 0.1)
    assert 0 < len(steps) < 5.0 * sim.physics_rate_hz
    steps.clear()
    assert vehicle_check._climbs_step(load_vehicle("husky"), sim, 0.1)  # upright, it climbs the same step


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
    # a high centre of mass: the vehicle turns over backwards at atan(a / h) before the grip gives
    assert climb_limit_deg(50.0, 0.6, 0.25, 2, 0.15, 1e6, 5.0) == pytest.approx(math.degrees(math.atan(0.25 / 0.6)))


def test_step_bound_geometry():
    from offroadbench.sim.rigs.vehicle_check import step_bound_m

    assert step_bound_m(0.165, 0.13, 0.512, overhang=True) == 0.13  # the nose strikes first
    assert step_bound_m(0.1, 0.3, 0.5, overhang=False) == pytest.approx(0.1, abs=1e-3)  # high belly: the radius
    low = step_bound_m(0.1, 0.02, 0.5, overhang=False)  # low belly, long wheelbase: the belly hangs up
    d = math.sqrt(2 * 0.1 * low - low**2)
    assert 0.02 < low < 0.1 and 0.02 + low * d / 0.5 == pytest.approx(low, abs=1e-3)
