"""Soil on both engines (issue 28, item 5): the ``terramechanics`` tyre model's force law is one
engine-neutral code (offroadbench.sim.tyre_laws.soil_wheels), and each engine only gathers a
wheel's state and applies the force. The single-wheel rigs of the two engines must agree, and a
vehicle on MuJoCo must sink and pull as the Wong-Reece integrals say."""

import dataclasses
import importlib.util
import math

import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig, open_world
from offroadbench.sim.engine import ENGINES, EngineCapabilities, engine_capabilities
from offroadbench.sim.rigs.soil_check import rig_curve
from offroadbench.sim.tyre_laws.terramechanics import load_soil, static_sinkage

needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")

R, B = 0.1651, 0.1143  # the Husky's wheel
#: the two engines' rigs agree within this fraction: of the sinkage, of the load (drawbar pull) and
#: of load x radius (torque). Both run the same force law on the same tables; what differs is the
#: engine's joints (PyBullet's velocity motors are constraints, MuJoCo's servos hold the speed to
#: about 1e-3 of the load's share) and its integrator. Measured: 0.03 % (sinkage), 0.015 % of the
#: load (pull), 0.2 % of load x radius (torque), lunar regolith at 1.62 m/s^2.
ENGINE_TOL = 0.01


@needs_mujoco
@pytest.mark.parametrize("soil_name, load_n, gravity", [("lunar-regolith", 60.0, 1.62), ("lete-sand", 120.0, 9.81)])
def test_the_engines_single_wheel_rigs_agree(soil_name, load_n, gravity):
    soil = load_soil(soil_name)
    slips = (0.0, 0.3, 0.6)
    a, b = (rig_curve(soil, R, B, load_n, gravity_m_s2=gravity, slips=slips, engine=e) for e in ("pybullet", "mujoco"))
    for i, s in enumerate(slips):
        assert b.sinkage_m[i] == pytest.approx(a.sinkage_m[i], rel=ENGINE_TOL), s
        assert abs(b.drawbar_pull_n[i] - a.drawbar_pull_n[i]) <= ENGINE_TOL * load_n, s
        assert abs(b.torque_nm[i] - a.torque_nm[i]) <= ENGINE_TOL * load_n * R, s
    assert b.drawbar_pull_n[2] > b.drawbar_pull_n[1] > b.drawbar_pull_n[0]  # pull rises with slip


@needs_mujoco
@pytest.mark.parametrize("gravity", [9.81, 1.62])
def test_a_vehicle_on_mujoco_settles_at_the_static_sinkage_and_reports_slip(gravity):
    soil = load_soil("lunar-regolith")
    sim = SimConfig(engine="mujoco", tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=gravity)
    with open_world(Heightmap.flat(81, 81, 0.05), "husky", sim) as world:
        world.spawn(2.0, 2.0, 0.0)
        load = world.geometry.mass_kg * gravity / 4
        assert world.wheel_penetration_m() == pytest.approx(static_sinkage(soil, R, B, load), rel=0.15)
        assert world.wheel_loads_n() == (0.0,) * 4  # the engine's wheel contact is off: the soil carries them
        assert world.wheel_slip() == pytest.approx(0.0, abs=0.05)
        world.command_wheels(4.0, 4.0)
        for _ in range(120):
            world.step()
        pos, _, lin, _ = world.base_state()
        assert 0.0 < world.wheel_slip() < 1.0 and lin[0] > 0.2 and math.isfinite(pos[2])


def test_engines_declare_their_tyre_models_and_the_config_checks_the_declaration():
    assert "terramechanics" in engine_capabilities("pybullet").tyre_models
    assert "terramechanics" in engine_capabilities("mujoco").tyre_models
    toy = EngineCapabilities(tyre_models=("coulomb",))

    def factory(hm, vehicle, sim):  # pragma: no cover - never opened
        raise AssertionError

    factory.capabilities = toy
    ENGINES.add("toy-engine", factory)
    try:
        assert engine_capabilities("toy-engine") is toy
        SimConfig(engine="toy-engine", tyre_model="coulomb")
        with pytest.raises(InputError, match="not implemented on engine 'toy-engine'; allowed there: coulomb"):
            SimConfig(engine="toy-engine", tyre_model="terramechanics")
        with pytest.raises(InputError, match="no single-wheel soil rig"):
            rig_curve(load_soil("lunar-regolith"), R, B, 60.0, slips=(0.0,), engine="toy-engine")
    finally:
        ENGINES._entries.pop("toy-engine", None)


def test_each_engines_own_settings_are_simconfig_keys_and_mujocos_table_is_validated():
    from offroadbench.sim.trial.pipeline import TrialSettings

    keys = {f.name for f in dataclasses.fields(SimConfig)}
    for name in ("pybullet", "mujoco"):
        assert set(engine_capabilities(name).settings) <= keys, name
    sim = TrialSettings.from_tables({"sim": {"engine": "mujoco", "mujoco": {"min_rate_hz": 240,
                                                                            "wheel_solref": [0.03, 1]}}}).sim
    assert sim.mujoco.min_rate_hz == 240 and sim.mujoco.wheel_solref == (0.03, 1.0)
    assert sim.mujoco.ccd_iterations == SimConfig().mujoco.ccd_iterations  # the others keep their defaults
    with pytest.raises(InputError, match="mujoco.cone"):
        TrialSettings.from_tables({"sim": {"mujoco": {"cone": "round"}}})
    with pytest.raises(InputError, match="unknown key"):
        TrialSettings.from_tables({"sim": {"mujoco": {"min_rate": 240}}})


@needs_mujoco
def test_the_mujoco_world_steps_at_its_tables_rate():
    sim = SimConfig(engine="mujoco", mujoco=dataclasses.replace(SimConfig().mujoco, min_rate_hz=240))
    with open_world(Heightmap.flat(41, 41, 0.05), "husky", sim) as world:
        assert world.substeps == 4 and world.contact.min_rate_hz == 240


@needs_mujoco
def test_soil_check_runs_on_mujoco_and_refuses_an_unknown_engine(capsys):
    from offroadbench.cli import main

    assert main(["soil", "check", "lunar-regolith", "--gravity", "1.62", "--engine", "mujoco"]) == 0
    out = capsys.readouterr().out
    assert "soil check: lunar-regolith" in out and "0.900" in out
    assert main(["soil", "check", "lunar-regolith", "--engine", "bulet"]) == 2
    assert "bulet" in capsys.readouterr().err
