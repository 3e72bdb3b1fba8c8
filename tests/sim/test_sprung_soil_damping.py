"""A sprung vehicle's soil contact is damped for the mass that moves with its wheel (the unsprung
mass below a strut), not its share of the vehicle: sized on the share, the HUNTER's wheels that left
their droop stops chattered on lunar regolith under PyBullet's 60 Hz explicit step, and vehicle
check's drawbar-pull and soft-soil climb rows failed there (offroadbench.sim.tyre_laws.soil_wheels.soil_setup)."""

from __future__ import annotations

import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig, load_vehicle, open_world
from offroadbench.sim.engines.base import unsprung_kg
from offroadbench.sim.rigs.soft_soil_check import SOFT_SOIL, SOFT_SOIL_GRAVITY_M_S2, tow_pull, towed_pull_n
from offroadbench.sim.tyre_laws.soil_wheels import soil_setup
from offroadbench.sim.tyre_laws.terramechanics import load_soil, static_sinkage, wheel_forces

DT = 1.0 / 60.0


def test_the_damping_mass_is_the_unsprung_mass_on_a_sprung_vehicle_and_the_share_on_a_rigid_one():
    hunter, husky = load_vehicle("hunter"), load_vehicle("husky")
    sprung = soil_setup(hunter, SOFT_SOIL, 65.0, 4, SOFT_SOIL_GRAVITY_M_S2, DT)
    assert sprung.share_kg == pytest.approx(16.25)
    assert sprung.damping_mass_kg == pytest.approx(unsprung_kg(hunter.urdf, hunter.suspension_joints)) == pytest.approx(4.0)
    flat = Heightmap.flat(9, 9, 0.5)
    assert sprung.wheels(4, flat, DT)._c == pytest.approx(0.5 * 4.0 / DT)
    rigid = soil_setup(husky, SOFT_SOIL, 50.0, 4, SOFT_SOIL_GRAVITY_M_S2, DT)
    assert rigid.damping_mass_kg is None and rigid.wheels(4, flat, DT)._c == pytest.approx(0.5 * 12.5 / DT)


def test_the_hunter_pulls_its_wong_reece_drawbar_pull_on_pybullet():
    """vehicle check's drawbar-pull row on PyBullet: -6.8 N against -5.2 N before (the chattering
    diagonal pair carried 31-32 N, the other two 20-21 N); within 10 % or 1 % of the weight now."""
    spec = load_vehicle("hunter")
    g = SOFT_SOIL_GRAVITY_M_S2
    sim = SimConfig(tyre_model="terramechanics", soil=SOFT_SOIL, gravity_m_s2=g, settle_time_s=0.5)
    with open_world(Heightmap.flat(161, 161, 0.05), spec, sim) as world:
        mass = world.geometry.mass_kg
        pull = tow_pull(world, 0.2)
    soil, r, b, load = load_soil(SOFT_SOIL), spec.wheel_radius_m, spec.wheel_width_m, mass * g / 4
    expected = 2 * float(wheel_forces(soil, r, b, static_sinkage(soil, r, b, load, 0.2), 0.2)[1])
    expected += 2 * towed_pull_n(soil, r, b, load)
    assert abs(pull - expected) <= max(0.1 * abs(expected), 0.01 * mass * g), (pull, expected)
