"""Steering kinds (issue 32): Ackermann geometry, the bicycle-model pure pursuit, corner steering in
place, the validated steering table, and the rocker differential on both engines."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial import skid_steer
from offroadbench.sim.trial.ackermann import bicycle_steer_rad
from offroadbench.sim.trial.steering import achievable, min_turn_radius_m, steered_commands
from offroadbench.sim.trial.vehicle import load_vehicle

HUNTER_LAYOUT = ((0.65, 0.3025), (0.0, 0.3025), (0.65, -0.3025), (0.0, -0.3025))  # FL, RL, FR, RR


def test_front_wheels_meet_the_ackermann_condition_and_the_rear_wheels_the_differential():
    spec = load_vehicle("hunter")
    v, omega = 1.0, 0.5
    speeds, (left, right) = steered_commands(v, omega, spec, HUNTER_LAYOUT)
    L, t = 0.65, 0.605
    # Gillespie 1992 eq. 6-1 (exact form): cot(outer) - cot(inner) = track / wheelbase; left is inner
    assert 1.0 / math.tan(right) - 1.0 / math.tan(left) == pytest.approx(t / L, rel=1e-12)
    radius = v / omega
    assert math.tan(left) == pytest.approx(L / (radius - t / 2), rel=1e-12)
    r = spec.wheel_radius_m
    assert speeds[1] * r == pytest.approx(v - omega * t / 2) and speeds[3] * r == pytest.approx(v + omega * t / 2)
    assert speeds[0] * r == pytest.approx(math.hypot(v - omega * t / 2, omega * L))


def test_a_car_cannot_turn_tighter_than_its_steering_limit_allows():
    spec = load_vehicle("hunter")
    r_min = min_turn_radius_m(spec, HUNTER_LAYOUT)
    assert r_min == pytest.approx(0.65 / math.tan(math.radians(33.2)) + 0.3025)
    v, w = achievable(1.0, 5.0, spec, HUNTER_LAYOUT)
    assert (v, w) == pytest.approx((1.0, 1.0 / r_min))
    _, angles = steered_commands(1.0, 5.0, spec, HUNTER_LAYOUT)
    assert max(angles) == pytest.approx(math.radians(33.2))  # the inner wheel at its limit, not past it
    assert achievable(0.0, 1.0, spec, HUNTER_LAYOUT) == (0.0, 0.0)  # no turn in place


def test_corner_steering_turns_in_place_with_every_wheel_on_the_circle():
    spec = load_vehicle("sojourner")
    layout = ((0.26, 0.2075), (0.0, 0.2075), (-0.26, 0.2075), (0.26, -0.2075), (0.0, -0.2075), (-0.26, -0.2075))
    assert min_turn_radius_m(spec, layout) == 0.0
    speeds, angles = steered_commands(0.0, 0.4, spec, layout)
    # steered corners: the wheel's rolling direction is perpendicular to its radius from the centre
    steered = dict(zip(spec.steered_wheel_joints, angles, strict=True))
    for name, (x, y), s in zip(spec.wheel_joints, layout, speeds, strict=True):
        a = steered.get(name, 0.0)
        assert math.cos(a) * x + math.sin(a) * y == pytest.approx(0.0, abs=1e-12)
        assert abs(s) * spec.wheel_radius_m == pytest.approx(0.4 * math.hypot(x, y))


def test_skid_steer_is_unchanged_and_saturates_as_before():
    spec = load_vehicle("husky")
    assert achievable(0.5, 2.0, spec) == skid_steer.achievable_twist(0.5, 2.0, spec)


def test_bicycle_pure_pursuit_follows_coulter():
    L, l = 0.65, 1.5
    alpha = math.radians(20)
    assert bicycle_steer_rad(alpha, l, L, 1.0) == pytest.approx(math.atan(2 * L * math.sin(alpha) / l))
    assert bicycle_steer_rad(alpha, l, L, 0.1) == 0.1
    assert bicycle_steer_rad(math.radians(-150), l, L, 0.5) == -0.5  # behind: full lock toward it


def test_the_steering_table_is_validated():
    spec = load_vehicle("hunter")
    with pytest.raises(InputError, match="steering"):
        dataclasses.replace(spec, steering="hover")
    with pytest.raises(InputError, match="steer_joints"):
        dataclasses.replace(spec, steer_joints=())
    with pytest.raises(InputError, match="differential_joints"):
        dataclasses.replace(load_vehicle("sojourner"), differential_joints=("left_rocker_joint",))
    with pytest.raises(InputError, match="driven_wheel_joints"):
        dataclasses.replace(spec, driven_wheel_joints=("no_such_joint",))


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_rocker_differential_keeps_the_rockers_opposite(engine):
    """A block under the left front wheel lifts the left rocker; the differential turns the right
    rocker the other way by the same angle, so the body pitches by the mean of the two."""
    from offroadbench.heightmap import Heightmap
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.engine import open_world

    spec = load_vehicle("sojourner")
    cell = 0.02
    x = np.arange(201) * cell
    X, Y = np.meshgrid(x, x)
    z = np.where((X > 2.18) & (X < 2.6) & (Y > 2.1) & (Y < 2.35), 0.06, 0.0)
    with open_world(Heightmap(z, cell), spec, SimConfig(engine=engine)) as w:
        w.spawn(2.0, 2.0, 0.0)
        for _ in range(120):
            w.step()
        if engine == "pybullet":
            import pybullet as pb

            cid, body = w.client_id, w.vehicle_id
            names = {pb.getJointInfo(body, j, physicsClientId=cid)[1].decode(): j
                     for j in range(pb.getNumJoints(body, physicsClientId=cid))}
            left, right = (pb.getJointState(body, names[n], physicsClientId=cid)[0] for n in spec.differential_joints)
        else:
            left, right = (float(w.data.qpos[w.model.joint(n).qposadr[0]]) for n in spec.differential_joints)
    assert abs(left) > 0.05  # the block moved the rockers
    assert left == pytest.approx(-right, abs=2e-3)


def test_the_car_follows_a_planned_arc_with_the_bicycle_tracker():
    """A trial with the Ackermann car: the bicycle-model tracker steers it along a lattice path that
    turns 90 degrees (spawned facing +x, goal to its left), never tighter than its turning radius."""
    from offroadbench.heightmap import Heightmap
    from offroadbench.navigation.drivers import planner_from_table
    from offroadbench.navigation.missions import Mission
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.engine import open_world
    from offroadbench.sim.trial.ackermann import BicycleTracker
    from offroadbench.sim.trial.runner import drive_mission, vehicle_envelope
    from offroadbench.sim.trial.steering import make_vehicle_tracker

    hm = Heightmap.flat(161, 161, 0.1)
    with open_world(hm, load_vehicle("hunter"), SimConfig()) as world:
        assert vehicle_envelope(world).min_turn_radius_m == pytest.approx(1.3, abs=0.01)
        assert isinstance(make_vehicle_tracker([(0.0, 0.0), (5.0, 0.0)], world.spec, ControllerConfig(), world),
                          BicycleTracker)
        mission = Mission(index=0, start_xy_m=(4.0, 4.0), goal_xy_m=(8.0, 10.0), heading_rad=0.0)
        rec = drive_mission(world, mission, planner=planner_from_table({"name": "lattice"}),
                            classes=np.zeros(hm.z.shape, dtype=np.uint8))
    assert rec.result.success, rec.result.failure_reason
    yaw_rate = np.abs(rec.telemetry["yaw_rate_body_rad_s"])
    speed = np.hypot(rec.telemetry["vx_m_s"], rec.telemetry["vy_m_s"])
    # never tighter than the smallest turning radius (a little slack for the tyres' slip)
    assert np.all(yaw_rate <= speed / 1.3 * 1.15 + 0.05)


def test_astar_refuses_a_car_and_lattice_keeps_to_its_turning_radius():
    from offroadbench.heightmap import Heightmap
    from offroadbench.navigation.planners import plan
    from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope

    z = np.zeros((121, 121))
    z[55:65, 35:55] = 0.5  # a wall across the straight line: the path must turn round it
    hm = Heightmap(z, 0.1)
    car = VehicleEnvelope(min_turn_radius_m=3.0)
    classes = np.where(z > 0, 2, 0).astype(np.uint8)
    problem = PlanningProblem(hm=hm, classes=classes, start_xy=(3.0, 3.0), goal_xy=(6.0, 9.0), vehicle=car)
    with pytest.raises(InputError, match="turn on the spot"):
        plan("astar", problem)
    path = plan("lattice", problem)
    # the lattice's arcs: the heading turns by at most step / R per arc length step (R = 3 m, not 1.5 m)
    seg = np.diff(path[:-1], axis=0)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    length = np.hypot(seg[:, 0], seg[:, 1])
    turn_rate = np.abs(np.diff(heading)) / (0.5 * (length[1:] + length[:-1]))
    assert 0.1 < turn_rate.max() <= 1.0 / 3.0 * 1.05
