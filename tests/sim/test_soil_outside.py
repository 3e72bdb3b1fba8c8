"""Where the soil model ends (issue 47): a wheel that bottoms out (its penetration past the soil
tables' top, the soil's sinkage cap reached) is outside the model, and the trial row records the
fraction of the trial it spent there, on both engines."""

import dataclasses
import importlib.util
import math

import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, open_world
from offroadbench.sim.trial.runner import drive_mission

needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
ENGINES = ["pybullet", pytest.param("mujoco", marks=needs_mujoco)]


def _drive(engine: str, soil: str, gravity: float, tyre_model: str = "terramechanics", loop: str | None = None):
    hm = Heightmap.flat(41, 81, 0.1)
    sim = SimConfig(tyre_model=tyre_model, soil=soil, gravity_m_s2=gravity, engine=engine)
    if loop is not None:
        sim = dataclasses.replace(sim, mujoco=dataclasses.replace(sim.mujoco, tyre_loop=loop))
    with open_world(hm, "husky", sim) as world:
        return drive_mission(world, Mission.between(0, (1.0, 2.0), (4.0, 2.0))).result


@pytest.mark.parametrize("engine", ENGINES)
def test_snow_under_earth_gravity_is_outside_the_model_and_regolith_is_not(engine):
    """Snow carries 69 N of a Husky wheel's 139 N at the 0.75 r cap (``soil check snow --gravity
    9.81``): the wheels ride on the tyre spring for most of the trial (0.86 of it measured on
    PyBullet); lunar regolith in lunar gravity
    carries the wheel at 9 mm, inside the model; rigid-ground tyres have no soil (NaN)."""
    snow = _drive(engine, "snow", 9.81)
    assert snow.outside_model_fraction > 0.5
    regolith = _drive(engine, "lunar-regolith", 1.62)
    assert regolith.outside_model_fraction == 0.0
    assert math.isnan(_drive(engine, "lunar-regolith", 9.81, tyre_model="coulomb").outside_model_fraction)


@needs_mujoco
def test_the_compiled_and_python_soil_loops_flag_alike():
    """MuJoCo's compiled soil loop reports the same flag as its Python loop."""
    pytest.importorskip("numba")
    a = _drive("mujoco", "snow", 9.81, loop="python")
    b = _drive("mujoco", "snow", 9.81, loop="compiled")
    assert a.outside_model_fraction == b.outside_model_fraction > 0.5
