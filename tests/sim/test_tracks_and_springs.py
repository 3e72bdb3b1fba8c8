"""The TALON's belts and the HUNTER's sprung wheels (issue 32) on both engines, and the vehicle check's
rules for them: a belt side drives through the road wheels that bear, a strut's travel follows its spring
rate, the track's step bound and a sprung vehicle's tip angle follow their derivations."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engine import open_world
from offroadbench.sim.engines.base import suspension_rest_m
from offroadbench.sim.rigs.vehicle_check import (TRACK_STEP_SPEED_M_S, _climbs_step, _step_world, sprung_tip_angle_deg,
                                                 track_step_bound_m)
from offroadbench.sim.trial.steering import drive_twist
from offroadbench.sim.trial.vehicle import load_vehicle

ENGINES = ["pybullet", "mujoco"]


# ---------------------------------------------------------------------------- the belt
def test_the_track_step_bound_follows_its_force_balance():
    r, mu, s, run = 0.075, 0.8, 0.5, 0.02
    h = track_step_bound_m(r, mu, s, run)
    # at the bound the face's angle from the vertical just meets tan(phi + atan mu) = s / (mu (1 - s))
    phi = math.atan2(run, h)
    assert math.tan(phi + math.atan(mu)) == pytest.approx(s / (mu * (1.0 - s)), rel=1e-3)
    assert h == pytest.approx(0.0889, abs=1e-4)
    # a vertical face: friction alone cannot lift half the weight when mu^2 < s / (1 - s): the wheel's centre
    assert track_step_bound_m(r, mu, s, 0.0) == r
    # more grip climbs higher; torque too small for the rub and the push holds it at the centre
    assert track_step_bound_m(r, 1.0, s, run) > h
    assert track_step_bound_m(r, mu, s, run, torque_ratio=0.1) == r


def test_a_belt_side_torque_goes_to_the_wheels_that_bear():
    from offroadbench.sim.engines.pybullet.drivetrain import belt_motor_forces

    # left side on its rear and front road wheels, right side in the air: the left's 12 N m by load, the right's evenly
    forces = belt_motor_forces([90.0, 0.0, 0.0, 0.0, 30.0] + [0.0] * 5, (5, 5), 2.4)
    assert forces[:5] == pytest.approx([9.0, 0.0, 0.0, 0.0, 3.0])
    assert forces[5:] == pytest.approx([2.4] * 5)
    assert sum(forces[:5]) == pytest.approx(12.0)


def _wheel_speeds(world, engine):
    if engine == "pybullet":
        import pybullet as pb

        return [pb.getJointState(world.vehicle_id, j, physicsClientId=world.client_id)[1] for j in world.wheel_joints]
    return [float(world.data.qvel[a]) for a in world._wheel_qvel]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_belt_side_turns_as_one_and_drives_through_the_wheel_against_the_step(engine):
    """Against a step too high to climb, the front road wheels press the face and the others hang in the
    air: each side's wheels still turn at one speed (without the belt the pressed wheel stalls and the
    rest spin at the command)."""
    spec = load_vehicle("talon")
    sim = SimConfig(engine=engine, settle_time_s=0.5)
    hm = _step_world(0.2, spec)
    speeds = {}
    for belt in (True, False):
        with open_world(hm, dataclasses.replace(spec, belt_drive=belt), sim) as w:
            w.spawn(3.4, hm.height_m / 2.0, 0.0)
            drive_twist(w, 0.5, 0.0)
            for _ in range(4 * sim.physics_rate_hz):
                w.step()
            speeds[belt] = np.array(_wheel_speeds(w, engine))
    n = len(spec.left_wheel_joints)
    for side in (speeds[True][:n], speeds[True][n:]):
        assert np.ptp(side) < 0.05 * max(1.0, np.abs(side).max())
    assert max(np.ptp(speeds[False][:n]), np.ptp(speeds[False][n:])) > 5.0  # one stalled, the rest spinning


@pytest.mark.parametrize("engine", ENGINES)
def test_the_belt_puts_the_sprocket_torque_through_the_front_wheel_onto_a_step(engine):
    """At a crawl the TALON climbs a 0.08 m step (above its road wheels' 0.075 m centre) only with the
    belt: its front wheel's rub on the face needs about 4 N m a side (track_step_bound_m: mu N r / 2 with
    N = 133 N), more than a fifth of the sprocket's 12 N m, which is all an unbelted wheel gets."""
    spec = load_vehicle("talon")
    sim = SimConfig(engine=engine, settle_time_s=0.5)
    assert _climbs_step(spec, sim, 0.08, TRACK_STEP_SPEED_M_S)
    assert not _climbs_step(dataclasses.replace(spec, belt_drive=False), sim, 0.08, TRACK_STEP_SPEED_M_S)


def test_the_belt_needs_a_skid_steered_vehicle_with_every_wheel_driven():
    with pytest.raises(InputError, match="belt_drive"):
        dataclasses.replace(load_vehicle("hunter"), belt_drive=True)


# ---------------------------------------------------------------------------- the springs
def _struts(world, engine):
    if engine == "pybullet":
        import pybullet as pb

        return [pb.getJointState(world.vehicle_id, j, physicsClientId=world.client_id)[0]
                for j in world.suspension_joints]
    return [float(world.data.qpos[world.model.joint(n).qposadr[0]]) for n in world.spec.suspension_joints]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_hunter_strut_travel_follows_its_spring_rate_under_static_load(engine):
    """Parked on Earth the preload holds the URDF's ride height; 200 N more on the chassis compresses each
    of the four struts by F / (4 k)."""
    spec = load_vehicle("hunter")
    k, force = spec.suspension_stiffness_n_m, 200.0
    with open_world(Heightmap.flat(81, 81, 0.1), spec, SimConfig(engine=engine)) as w:
        w.spawn(4.0, 4.0, 0.0)
        for _ in range(120):
            w.step()
        parked = np.array(_struts(w, engine))
        for _ in range(180):
            w.push_base(0.0, 0.0, -force)
            w.step()
        loaded = np.array(_struts(w, engine))
    assert np.abs(parked).max() < 1e-3
    assert loaded - parked == pytest.approx(np.full(4, force / (4.0 * k)), rel=0.03)


@pytest.mark.parametrize("engine", ENGINES)
def test_in_lunar_gravity_the_struts_rest_on_their_droop_stops(engine):
    spec = load_vehicle("hunter")
    assert suspension_rest_m(spec, 1.62) == -0.05  # (12.25 kg * 1.62 - 120.17 N) / k = -0.052 m: the stop
    assert suspension_rest_m(spec, 9.81) == pytest.approx(0.0, abs=1e-4)
    with open_world(Heightmap.flat(81, 81, 0.1), spec, SimConfig(engine=engine, gravity_m_s2=1.62)) as w:
        w.spawn(4.0, 4.0, 0.0)
        for _ in range(120):
            w.step()
        assert np.array(_struts(w, engine)) == pytest.approx(np.full(4, -0.05), abs=3e-3)


def test_suspension_fields_come_together():
    spec = load_vehicle("hunter")
    with pytest.raises(InputError, match="suspension_joints need"):
        dataclasses.replace(spec, suspension_damping_n_s_m=None)
    with pytest.raises(InputError, match="without suspension_joints"):
        dataclasses.replace(load_vehicle("husky"), suspension_stiffness_n_m=1000.0)


def test_the_sprung_tip_angle_is_the_geometric_one_on_stiff_springs_and_lower_on_soft():
    args = dict(mass_kg=65.0, unsprung_kg=4.0, com_height_m=0.2, wheel_radius_m=0.165, track_m=0.605,
                preload_n=120.17, droop_m=0.05, bump_m=0.05)
    rigid = math.degrees(math.atan2(0.3025, 0.2))
    assert sprung_tip_angle_deg(stiffness_n_m=1e9, **args) == pytest.approx(rigid, abs=1e-3)
    # the HUNTER's springs: its body rolls about 6 deg toward the downhill wheels before the tip
    assert 52.0 < sprung_tip_angle_deg(stiffness_n_m=1934.0, **args) < rigid - 1.0
