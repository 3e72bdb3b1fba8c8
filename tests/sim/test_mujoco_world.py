"""The MuJoCo world (offroadbench.sim.engines.mujoco.world): the same terrain, vehicle and checks as the
PyBullet world, behind the same engine boundary (offroadbench.sim.engine)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig, TrialWorld, World, open_world

pytest.importorskip("mujoco")

CELL = 0.05
MUJOCO = SimConfig(engine="mujoco")


def _smooth_map(rows=121, cols=161):
    y, x = np.mgrid[0:rows, 0:cols] * CELL
    return Heightmap(0.8 + 0.35 * np.sin(2 * np.pi * x / 4.0) + 0.25 * np.cos(2 * np.pi * y / 3.0) + 0.02 * x, CELL)


def test_terrain_sits_where_the_heightmap_says():
    hm = _smooth_map()
    with open_world(hm, "husky", MUJOCO) as world:
        assert isinstance(world, TrialWorld) and type(world).__name__ == "MuJoCoWorld"
        for r, c in [(1, 1), (5, 150), (119, 3), (60, 80), (118, 158)]:
            # the hfield holds float32 elevations over the relief: exact to ~1e-7 of it
            assert world.ray_height(c * CELL, r * CELL) == pytest.approx(hm.z[r, c], abs=1e-6)
        rng = np.random.default_rng(0)
        x, y = rng.uniform(0.1, hm.width_m - 0.1, 100), rng.uniform(0.1, hm.height_m - 0.1, 100)
        ray = np.array([world.ray_height(a, b) for a, b in zip(x, y, strict=True)])
        assert np.abs(ray - hm.height_at(x, y)).max() < 3e-3
        assert math.isnan(world.ray_height(-1.0, 2.0))


@pytest.mark.parametrize("vehicle", ["husky", "jackal"])
def test_geometry_matches_the_pybullet_world(vehicle):
    """The same URDF measured by both engines: masses, spin inertias and wheel centres agree to
    rounding; lengths and the belly within Bullet's 1 mm box margin."""
    hm = Heightmap.flat(41, 41, CELL)
    with World(hm, vehicle) as pb_world, open_world(hm, vehicle, MUJOCO) as mj_world:
        a, b = pb_world.geometry, mj_world.geometry
    assert b.mass_kg == pytest.approx(a.mass_kg, rel=1e-9)
    assert b.wheel_spin_inertia_kg_m2 == pytest.approx(a.wheel_spin_inertia_kg_m2, rel=1e-6)
    assert np.allclose(b.wheel_centres_m, a.wheel_centres_m, atol=1e-9)
    assert b.length_m == pytest.approx(a.length_m, abs=3e-3) and b.width_m == pytest.approx(a.width_m, abs=3e-3)
    assert b.belly_m == pytest.approx(a.belly_m, abs=2e-3) and b.overhang == a.overhang


def test_settled_vehicle_carries_its_weight_and_tilted_gravity_shifts_it():
    with open_world(Heightmap.flat(81, 81, CELL, z_m=0.3), "husky", MUJOCO) as world:
        world.spawn(2.0, 2.0, math.radians(30))
        loads = world.wheel_loads_n()
        assert min(loads) > 0
        assert sum(loads) == pytest.approx(world.geometry.mass_kg * 9.81, rel=0.05)
        assert world.centre_of_mass_m()[2] - 0.3 == pytest.approx(0.189, abs=0.01)
        assert 0.0 < world.wheel_penetration_m() < 0.02
        (x, y, _), q, lin, ang = world.base_state()
        assert (x, y) == pytest.approx((2.0, 2.0), abs=0.01) and max(map(abs, lin + ang)) < 0.05
        r = world.rotation_matrix(q)
        assert math.degrees(math.atan2(r[3], r[0])) == pytest.approx(30.0, abs=0.5)
        g = 9.81
        world.set_gravity(0.0, -g * math.sin(math.radians(20)), -g * math.cos(math.radians(20)))
        for _ in range(30):
            world.step()
        assert sum(world.wheel_loads_n()[:2]) < sum(world.wheel_loads_n()[2:])  # the downhill (right) side


@pytest.mark.parametrize("vehicle", ["husky", "jackal"])
def test_vehicle_check_passes_on_mujoco(vehicle):
    """Every physical figure of ``vehicle check`` within its tolerance on MuJoCo as on PyBullet
    (the Husky's spec-sheet climb of 45 deg needs mu >= 1 on both: grip-limited at mu = 0.8)."""
    from offroadbench.sim.rigs.vehicle_check import check_vehicle

    rows = check_vehicle(vehicle, MUJOCO, headings_deg=(0.0, 22.5, 45.0), yaw_commands_rad_s=(0.5, 2.0))
    failed = [r for r in rows if not r.ok and r.name != "steepest grade climbed vs spec sheet"]
    assert failed == []


def test_a_missing_mujoco_is_an_input_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ModuleNotFoundError
    monkeypatch.delitem(sys.modules, "offroadbench.sim.engines.mujoco.world", raising=False)
    with pytest.raises(InputError, match=r"engine 'mujoco' needs the mujoco package: pip install 'offroadbench\[mujoco\]'"):
        open_world(Heightmap.flat(41, 41, CELL), "husky", MUJOCO)


def test_a_mujoco_trial_is_bit_identical_in_another_process():
    """The same mission in a fresh process gives the same row to the last bit (MuJoCo is compiled
    without CPU dispatch in its wheel; the trial loop is dispatch-free Python)."""
    import subprocess

    code = (
        "from offroadbench.heightmap import Heightmap\n"
        "from offroadbench.navigation.missions import Mission\n"
        "from offroadbench.sim import SimConfig, open_world, run_mission\n"
        "import numpy as np\n"
        "y, x = np.mgrid[0:81, 0:201] * 0.05\n"
        "hm = Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y), 0.05)\n"
        "with open_world(hm, 'husky', SimConfig(engine='mujoco')) as w:\n"
        "    r, _ = run_mission(w, Mission.between(0, (2, 2), (8, 2)))\n"
        "print(repr(r))\n"
    )
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
            for _ in range(2)]
    assert runs[0] == runs[1] and "TrialResult(" in runs[0]
    ns = {}
    exec(code.replace("print(repr(r))\n", ""), ns)
    assert repr(ns["r"]) + "\n" == runs[0]
