"""The compiled soil loop of the MuJoCo world (offroadbench.sim.engines.mujoco._soil_c) against the Python
loop (offroadbench.sim.tyre_laws.soil_wheels.SoilWheels and MuJoCoWorld's soil forces): the same
forces, to the last bit."""

from __future__ import annotations

import numpy as np
import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, run_mission
from offroadbench.sim.trial.vehicle import load_vehicle
from offroadbench.sim.tyre_laws.soil_wheels import soil_setup

pytest.importorskip("mujoco")
pytest.importorskip("numba")

from offroadbench.sim.engines.mujoco import _soil_c as sc  # noqa: E402
from offroadbench.sim.engines.mujoco.world import ContactTuning, MuJoCoWorld  # noqa: E402

SOIL = SimConfig(engine="mujoco", tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=1.62)


def _rough_map() -> Heightmap:
    y, x = np.mgrid[0:81, 0:201] * 0.05
    return Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.03 * np.sin(5.3 * y + 0.7 * x), 0.05)


def test_soil_forces_match_the_python_soil_wheels_over_random_contact_states():
    """3,000 random wheel states (centres above, in and below the soil and off the map; tilted axles;
    velocities from creeping to fast, driving, skidding and sliding sideways; stored slip states
    fresh, small and saturated) give exactly the Python law's forces, torques, slip states and
    last-step (sinkage, slip, penetration)."""
    rng = np.random.default_rng(3535)
    hm = _rough_map()
    spec = load_vehicle("husky")
    n, dt = 4, 1 / 60
    setup = soil_setup(spec, "lunar-regolith", 50.0, n, 1.62, dt)
    py = setup.wheels(n, hm, dt, dt / 2)
    f, st, tab = sc.new_state(py, hm, [1, 2, 3, 4], [6, 7, 8, 9], [(0.0, 1.0, 0.0)] * n, 0)
    r = spec.wheel_radius_m
    kinds = {"touch": 0, "miss": 0, "off": 0, "saturated": 0, "reverse": 0}
    for trial in range(3000):
        i = int(rng.integers(n))
        x = float(rng.uniform(-0.5, 10.5))
        y = float(rng.uniform(-0.3, 4.3))
        ground = float(hm.height_at(min(max(x, 0.0), 10.0), min(max(y, 0.0), 4.0)))
        centre = (x, y, ground + r + float(rng.normal(-0.02, 0.03)))
        axle = np.array([0.0, 1.0, 0.0]) + rng.normal(0.0, 0.2, 3)
        axle = tuple((axle / np.linalg.norm(axle)).tolist())
        lin = tuple(rng.normal(0.0, 10 ** rng.uniform(-4, 0.5), 3).tolist())
        ang = tuple(rng.normal(0.0, 10 ** rng.uniform(-3, 1.2), 3).tolist())
        if rng.integers(4) == 0:
            py._state[i] = None
            f[2 * i:2 * i + 2] = 0.0
        else:
            state = [float(rng.normal(0.0, py._sx)), float(rng.normal(0.0, 5 * py._sy))]
            py._state[i] = list(state)
            f[2 * i:2 * i + 2] = state
        py.begin()
        st[:n] = 0
        want = py.wheel_force(i, centre, axle, lin, ang)
        got = sc.wheel_force(f, st, tab, i, *centre, *axle, *lin, *ang)
        if want is None:
            assert not got[0], trial
            assert py._state[i] is None and f[2 * i] == 0.0 and f[2 * i + 1] == 0.0 and st[i] == 0
            kinds["off" if not (0 <= x <= 10 and 0 <= y <= 4) else "miss"] += 1
            continue
        assert got[0] and got[1:] == (*want[0], *want[1]), (trial, got, want)
        assert list(f[2 * i:2 * i + 2]) == py._state[i]
        assert st[i] == 1 and tuple(f[2 * n + 3 * i:2 * n + 3 * i + 3]) == py.last[i]
        kinds["touch"] += 1
        kinds["saturated"] += abs(py._state[i][0]) == py._sx
        kinds["reverse"] += py.last[i][1] * py._state[i][0] < 0
    assert kinds["touch"] > 1000 and kinds["miss"] > 100 and kinds["off"] > 50  # every branch exercised
    assert kinds["saturated"] > 50 and kinds["reverse"] > 50


def _lockstep(steps, command, **tuning):
    hm = _rough_map()
    worlds = [MuJoCoWorld(hm, "husky", SOIL, ContactTuning(tyre_loop=loop, **tuning)) for loop in ("python", "compiled")]
    try:
        for w in worlds:
            w.spawn(2.0, 2.0, 0.3)
        for t in range(steps):
            for w in worlds:
                w.command_wheels(*command(t))
                if t % 40 == 20:
                    w.push_base(0.0, 40.0, 0.0)
                w.step()
            yield worlds
    finally:
        for w in worlds:
            w.close()


@pytest.mark.parametrize("each", [True, False])
def test_a_soil_drive_with_the_compiled_loop_applies_the_python_loops_forces(each):
    """Two worlds on lunar regolith, one per loop, driven in lockstep over rough ground (driving,
    turning, reversing, pushed sideways now and then): at every step the applied forces, the
    vehicle's state, the sinkage, the slip and the loads are the same bits; with the forces computed
    at every MuJoCo step or held over the trial step."""
    def command(t):
        return (6.0, 2.0) if t < 100 else (-3.0, 4.0)

    sinks, slips = [], []
    for python, compiled in _lockstep(180, command, tyres_each_substep=each):
        assert python._fast_soil is None and compiled._fast_soil is not None
        assert np.array_equal(compiled.data.xfrc_applied, python.data.xfrc_applied)
        assert np.array_equal(compiled.data.qpos, python.data.qpos) and np.array_equal(compiled.data.qvel, python.data.qvel)
        assert compiled.wheel_penetration_m() == python.wheel_penetration_m()
        assert compiled.wheel_slip() == python.wheel_slip()
        assert compiled.wheel_loads_n() == python.wheel_loads_n()
        sinks.append(python.wheel_penetration_m())
        slips.append(python.wheel_slip())
    assert min(sinks) > 0.0 and max(abs(s) for s in slips) > 0.05  # on the soil throughout, slipping


def test_a_soil_mission_row_is_the_same_with_either_loop():
    hm = _rough_map()
    rows = []
    for loop in ("python", "compiled"):
        with MuJoCoWorld(hm, "husky", SOIL, ContactTuning(tyre_loop=loop)) as w:
            assert (w._fast_soil is not None) == (loop == "compiled")
            r, tel = run_mission(w, Mission.between(0, (2, 2), (6, 2.5)))
            rows.append((repr(r), tel))
    assert rows[0][0] == rows[1][0] and "success=True" in rows[0][0] and "mean_slip=nan" not in rows[0][0]
    assert all(np.array_equal(rows[0][1][k], rows[1][1][k], equal_nan=True) for k in rows[0][1])


@pytest.mark.parametrize("model", ["coulomb", "terramechanics"])
def test_articulated_vehicles_keep_the_python_loop(model):
    """The compiled loops take a wheel's velocity from the chassis' rigid motion and its spin; a
    vehicle whose wheels also move on rockers or steering joints keeps the Python loop (which asks
    MuJoCo for each wheel body's velocity), so both settings give its rows."""
    hm = Heightmap.flat(61, 61, 0.05)
    sim = SimConfig(engine="mujoco", tyre_model=model, soil="lunar-regolith")
    with MuJoCoWorld(hm, "sojourner", sim, ContactTuning(tyre_loop="compiled")) as w:
        assert w._articulated and w._fast is None and w._fast_soil is None
    with MuJoCoWorld(hm, "husky", sim, ContactTuning(tyre_loop="compiled")) as w:
        assert (w._fast is not None) == (model == "coulomb") and (w._fast_soil is not None) == (model != "coulomb")


def test_the_compiled_soil_loop_gives_the_python_row_when_compiled_for_the_x86_64_baseline(tmp_path):
    """Compiled for the x86-64 baseline (no AVX, no FMA: ``NUMBA_CPU_NAME=x86-64``, a fresh cache)
    the soil loop gives the Python loop's row to the last bit, as on the host CPU: the result does
    not depend on the CPU's SIMD."""
    from tests.compiled_baseline import run_compiled_for_x86_64_baseline

    code = (
        "import numpy as np\n"
        "from offroadbench.heightmap import Heightmap\n"
        "from offroadbench.navigation.missions import Mission\n"
        "from offroadbench.sim import SimConfig, run_mission\n"
        "from offroadbench.sim.engines.mujoco.world import ContactTuning, MuJoCoWorld\n"
        "y, x = np.mgrid[0:81, 0:201] * 0.05\n"
        "hm = Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.03 * np.sin(5.3 * y + 0.7 * x), 0.05)\n"
        "sim = SimConfig(engine='mujoco', tyre_model='terramechanics', soil='lunar-regolith', gravity_m_s2=1.62)\n"
        "with MuJoCoWorld(hm, 'husky', sim, ContactTuning(tyre_loop=LOOP)) as w:\n"
        "    assert (w._fast_soil is not None) == (LOOP == 'compiled')\n"
        "    r, _ = run_mission(w, Mission.between(0, (2, 2), (6, 2.5)))\n"
        "print(repr(r))\n"
    )
    baseline = run_compiled_for_x86_64_baseline(code.replace("LOOP", "'compiled'"), tmp_path)
    ns = {}
    exec(code.replace("LOOP", "'python'").replace("print(repr(r))\n", ""), ns)
    assert baseline == repr(ns["r"]) + "\n" and "success=True" in baseline


def test_the_soil_loop_is_selectable_and_auto_falls_back_to_python_without_numba(monkeypatch):
    import sys

    from offroadbench.errors import InputError

    hm = Heightmap.flat(41, 41, 0.05)
    with MuJoCoWorld(hm, "husky", SOIL, ContactTuning(tyre_loop="python")) as w:
        assert w._fast_soil is None and w._soil is not None
    with MuJoCoWorld(hm, "husky", SOIL) as w:
        assert w._fast_soil is not None and w._fast is None  # auto, numba installed
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba now raises ImportError
    monkeypatch.delitem(sys.modules, "offroadbench.sim.engines.mujoco._soil_c", raising=False)
    monkeypatch.delattr("offroadbench.sim.engines.mujoco._soil_c", raising=False)
    with MuJoCoWorld(hm, "husky", SOIL) as w:
        assert w._fast_soil is None and w._soil is not None
    with pytest.raises(InputError, match=r"MuJoCoConfig.tyre_loop = 'compiled' needs numba"):
        MuJoCoWorld(hm, "husky", SOIL, ContactTuning(tyre_loop="compiled"))
