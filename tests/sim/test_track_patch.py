"""The track patch (issue 47): a tracked vehicle's belts on soft soil under the Bekker / Wong track
relations, on both engines, against the relations' closed forms."""

import dataclasses
import importlib.util
import math

import pytest
from scipy import integrate

from offroadbench.heightmap import Heightmap
from offroadbench.sim.tyre_laws.soil_wheels import belt_segment
from offroadbench.sim.tyre_laws.terramechanics import load_soil
from offroadbench.sim.tyre_laws.track_patch import (TrackPatch, compaction_resistance_n, drawbar_pull_n, segment_table,
                                                    shear_development, track_sinkage_m, track_thrust_n)

needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
ENGINES = ["pybullet", pytest.param("mujoco", marks=needs_mujoco)]
B, L = 0.10, 0.71  # the TALON's belt


@pytest.mark.parametrize("soil_name", ["lunar-regolith", "lete-sand", "snow"])
@pytest.mark.parametrize("slip", [0.05, 0.2, 0.9])
def test_thrust_is_the_janosi_hanamoto_integral_along_the_belt(soil_name, slip):
    """F = b int_0^L (c + p tan phi)(1 - exp(-i x / K)) dx at uniform pressure p = W / (b L), by scipy."""
    soil = load_soil(soil_name)
    w = 130.0
    p = w / (B * L)
    tau = lambda x: (soil.cohesion_pa + p * math.tan(math.radians(soil.friction_angle_deg))) * (  # noqa: E731
        1.0 - math.exp(-slip * x / soil.shear_modulus_m))
    want = B * integrate.quad(tau, 0.0, L, epsabs=1e-10)[0]
    assert track_thrust_n(soil, B, L, w, slip) == pytest.approx(want, rel=1e-9)
    assert track_thrust_n(soil, B, L, w, -slip) == pytest.approx(-want, rel=1e-9)


def test_sinkage_and_compaction_resistance_are_bekkers():
    soil = load_soil("snow")  # n = 1.6
    w = 60.0
    z0 = track_sinkage_m(soil, B, L, w)
    k = soil.k_c / B + soil.k_phi
    assert k * z0**soil.n == pytest.approx(w / (B * L), rel=1e-12)  # p = k z^n
    rc = integrate.quad(lambda z: B * k * z**soil.n, 0.0, z0)[0]  # the work of pressing the belt down, per metre
    assert compaction_resistance_n(soil, B, z0) == pytest.approx(rc, rel=1e-9)
    assert drawbar_pull_n(soil, B, L, w, 0.3) == pytest.approx(track_thrust_n(soil, B, L, w, 0.3) - rc, rel=1e-9)
    assert shear_development(1e-7) == pytest.approx(0.5e-7 - 1e-14 / 6, rel=1e-6)  # u / 2 - u^2 / 6 + ...
    assert shear_development(3.0) == pytest.approx(1.0 - (1.0 - math.exp(-3.0)) / 3.0, rel=1e-14)
    assert 0.0 < shear_development(0.1) < shear_development(5.0) < 1.0


@pytest.mark.parametrize("soil_name", ["lunar-regolith", "snow"])
def test_the_segments_of_a_uniformly_loaded_belt_sum_to_the_closed_forms(soil_name):
    """N segments at the penetration that carries W / N each: normal forces sum to W, thrusts to the
    belt's thrust, compaction resistances to R_c, side forces to the lateral form with K_y."""
    soil = load_soil(soil_name)
    patch = TrackPatch(contact_length_m=L, width_m=B, segments=5)
    table = segment_table(soil, patch, 0.075, 8000.0, 0.75 * 0.075)
    w = 60.0
    lo, hi = 0.0, table.delta_max_m
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if table.lookup(mid)[1] < w / 5 else (lo, mid)
    segs = [belt_segment(table, hi, 0.25, 0.1, 1.0, 0.0, 0.075) for _ in range(5)]
    assert sum(s[1] for s in segs) == pytest.approx(w, rel=1e-6)
    assert sum(s[0] for s in segs) / 5 == pytest.approx(track_sinkage_m(soil, B, L, w), rel=1e-3)
    assert sum(s[2] for s in segs) == pytest.approx(drawbar_pull_n(soil, B, L, w, 0.25), rel=1e-3)
    assert sum(s[3] for s in segs) == pytest.approx(0.075 * track_thrust_n(soil, B, L, w, 0.25), rel=1e-6)
    lateral = track_thrust_n(soil, B, L, w, 0.1, shear_modulus_m=soil.lateral_shear_modulus_m)
    assert sum(s[4] for s in segs) == pytest.approx(lateral, rel=1e-6)


def _talon_world(engine: str, gravity: float):
    from offroadbench.sim import SimConfig, open_world

    sim = SimConfig(tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=gravity, engine=engine)
    return open_world(Heightmap.flat(121, 201, 0.05), "talon", sim)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("gravity", [1.62, 9.81])
def test_the_talon_settles_at_the_belts_closed_form_sinkage(engine, gravity):
    """On flat lunar regolith the belts' sinkage is Bekker's z0 = (W / (b L k))^(1/n) for W = m g / 2 a
    track (0.37 mm in lunar, 2.25 mm in Earth gravity; the rows of wheels sank 10 mm and more)."""
    from offroadbench.sim.rigs.soft_soil_check import come_to_rest

    with _talon_world(engine, gravity) as world:
        world.spawn(2.0, 3.0, 0.0)
        come_to_rest(world)
        z0 = track_sinkage_m(load_soil("lunar-regolith"), B, L, world.geometry.mass_kg * gravity / 2)
        assert world.wheel_penetration_m() == pytest.approx(z0, rel=0.01)
        assert not world.wheel_outside_model()


@pytest.mark.parametrize("engine", ENGINES)
def test_the_talons_drawbar_pull_is_the_belts_thrust_less_its_resistance(engine):
    """A drag on the chassis fed back to hold the belts at 20 % slip (16 s, as the vehicle check's tow
    rig): the drag the TALON holds is 2 (F(i) - R_c) at the slip it runs at, within 2 %."""
    from offroadbench.sim.rigs.soft_soil_check import tow_pull

    g = 9.81
    with _talon_world(engine, g) as world:
        pull = tow_pull(world, 0.2, seconds=16.0)
        slip = world.wheel_slip()
        m = world.geometry.mass_kg
    want = 2 * drawbar_pull_n(load_soil("lunar-regolith"), B, L, m * g / 2, slip)
    assert abs(slip - 0.2) < 0.01
    assert pull == pytest.approx(want, rel=0.02)


def test_rigid_ground_keeps_the_rows_of_wheels():
    """The track patch is a soft-soil law: on the coulomb tyre model the TALON has no soil at all."""
    from offroadbench.sim import SimConfig, open_world
    from offroadbench.sim.trial.vehicle import load_vehicle

    spec = load_vehicle("talon")
    assert spec.track_contact_length_m == L and spec.wheel_width_m == B
    with open_world(Heightmap.flat(61, 61, 0.05), spec, SimConfig(tyre_model="coulomb")) as world:
        world.spawn(1.5, 1.5, 0.0)
        assert world.wheel_slip() is None and world.wheel_outside_model() is None
    with pytest.raises(Exception, match="track_contact_length_m"):
        dataclasses.replace(spec, wheel_width_m=None)
