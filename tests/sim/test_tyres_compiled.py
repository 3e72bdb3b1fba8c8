"""The compiled coulomb tyre loop of the MuJoCo world (offroadbench.sim.engines.mujoco._tyres_c) against the
Python loop (offroadbench.sim.tyre_laws.coulomb.CoulombBristles and MuJoCoWorld's contact reading)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, open_world, run_mission
from offroadbench.sim.tyre_laws.coulomb import CoulombBristles

pytest.importorskip("mujoco")
pytest.importorskip("numba")

from offroadbench.sim.engines.mujoco import _tyres_c as tc  # noqa: E402
from offroadbench.sim.engines.mujoco.settings import MuJoCoConfig  # noqa: E402
from offroadbench.sim.engines.mujoco.world import ContactTuning, MuJoCoWorld  # noqa: E402

MUJOCO = SimConfig(engine="mujoco")
REL = 1e-9


def _close(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return bool(np.all(np.abs(a - b) <= REL * np.maximum(np.abs(a), np.abs(b)) + 1e-300))


def _rough_map() -> Heightmap:
    y, x = np.mgrid[0:81, 0:201] * 0.05
    return Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.03 * np.sin(5.3 * y + 0.7 * x), 0.05)


def test_wheel_forces_match_the_python_bristles_over_random_contact_states():
    """2,000 random contact states (loads, points, normals, velocities, stored deflections; sticking
    and sliding, fresh and held bristles) give the Python law's forces, points and new deflections."""
    rng = np.random.default_rng(35)
    n, mu, dt, k, c = 4, 0.8, 1 / 120, 4.0e4, 9.0e2
    py = CoulombBristles(n, mu, dt, stiffness_n_m=k, damping_n_s_m=c)
    f, st = tc.new_state(n, mu, dt, k, c, [1, 2, 3, 4], [6, 7, 8, 9], [(0.0, 1.0, 0.0)] * n, 0, 1, [-1] * 6)
    slides = sticks = 0
    for trial in range(2000):
        i = int(rng.integers(n))
        fn = float(rng.uniform(1.0, 400.0))
        point = rng.normal(0.0, 2.0, 3)
        normal = rng.normal(0.0, 1.0, 3) + np.array([0.0, 0.0, 2.0])
        acc = [fn, *(fn * point), *(fn * normal)]
        py.acc[7 * i:7 * i + 7] = acc
        f[7 * i:7 * i + 7] = acc
        held = bool(rng.integers(2))
        bristle = rng.normal(0.0, 10 ** rng.uniform(-6, -2), 3).tolist()
        py._held[i] = held
        py._bristle[3 * i:3 * i + 3] = bristle
        st[n + i] = int(held)
        f[7 * n + 3 * i:7 * n + 3 * i + 3] = bristle
        centre = tuple(point + rng.normal(0.0, 0.1, 3))
        lin = tuple(rng.normal(0.0, 10 ** rng.uniform(-4, 0.5), 3))
        ang = tuple(rng.normal(0.0, 10 ** rng.uniform(-3, 1), 3))
        want = py.wheel_force(i, centre, lin, ang)
        got = tc.wheel_force(f, st, i, *centre, *lin, *ang)
        assert _close(got, want), (trial, got, want)
        assert _close(f[7 * n + 3 * i:7 * n + 3 * i + 3], py._bristle[3 * i:3 * i + 3]) and st[n + i] == 1
        slipping = math.hypot(*want[:3]) >= mu * fn * (1 - 1e-12)
        slides += slipping
        sticks += not slipping
    assert slides > 200 and sticks > 200  # both branches of the law were exercised


def _lockstep(tyre_loops, steps, command, **tuning):
    hm = _rough_map()
    worlds = [MuJoCoWorld(hm, "husky", MUJOCO, ContactTuning(tyre_loop=loop, **tuning)) for loop in tyre_loops]
    try:
        for w in worlds:
            w.spawn(2.0, 2.0, 0.3)
        for t in range(steps):
            for w in worlds:
                w.command_wheels(*command(t))
                w.step()
            yield worlds
    finally:
        for w in worlds:
            w.close()


@pytest.mark.parametrize("each", [True, False])
def test_a_drive_with_the_compiled_loop_applies_the_python_loops_forces(each):
    """Two worlds, one per loop, driven in lockstep over rough ground (turning, so every wheel
    slips): at every step the applied tyre forces, the loads, the penetration and the vehicle's
    state agree to 1e-9 relative (in fact to the last bit: the same IEEE operations in the same
    order); with the forces computed at every MuJoCo step or held over the trial step."""
    def command(t):
        return (6.0, 2.0) if t < 120 else (-3.0, 4.0)

    steps, biggest, lightest = 0, 0.0, math.inf
    for python, compiled in _lockstep(("python", "compiled"), 240, command, tyres_each_substep=each):
        assert python._fast is None and compiled._fast is not None
        assert _close(compiled.data.xfrc_applied, python.data.xfrc_applied)
        assert _close(compiled.wheel_loads_n(), python.wheel_loads_n())
        assert _close(compiled.wheel_penetration_m(), python.wheel_penetration_m())
        assert _close(compiled.data.qpos, python.data.qpos) and _close(compiled.data.qvel, python.data.qvel)
        steps += 1
        biggest = max(biggest, float(np.abs(python.data.xfrc_applied).max()))
        lightest = min(lightest, sum(python.wheel_loads_n()))
    assert steps == 240
    assert biggest > 10.0 and lightest > 0  # tyre forces were applied, on the ground throughout


def test_a_mission_row_is_the_same_with_either_loop():
    hm = _rough_map()
    rows = []
    for loop in ("python", "compiled"):
        with MuJoCoWorld(hm, "husky", MUJOCO, ContactTuning(tyre_loop=loop)) as w:
            r, tel = run_mission(w, Mission.between(0, (2, 2), (8, 3)))
            rows.append((repr(r), tel))
    assert rows[0][0] == rows[1][0] and "success=True" in rows[0][0]
    assert all(np.array_equal(rows[0][1][k], rows[1][1][k], equal_nan=True) for k in rows[0][1])


def test_pushing_the_base_with_the_compiled_loop_matches_the_python_loop():
    def command(t):
        return (1.0, 1.0)

    y = 2.0
    for t, (python, compiled) in enumerate(_lockstep(("python", "compiled"), 30, command)):
        if t % 10 == 0:
            for w in (python, compiled):
                w.push_base(0.0, 300.0, 0.0)
        assert _close(compiled.data.qpos, python.data.qpos)
        y = float(python.data.qpos[1])
    assert y > 2.01  # the pushes moved it sideways


def test_the_loop_is_selectable_and_auto_falls_back_to_python_without_numba(monkeypatch):
    hm = Heightmap.flat(41, 41, 0.05)
    with MuJoCoWorld(hm, "husky", MUJOCO, ContactTuning(tyre_loop="python")) as w:
        assert w._fast is None
    with MuJoCoWorld(hm, "husky", MUJOCO) as w:
        assert w._fast is not None  # auto, numba installed
    with MuJoCoWorld(hm, "husky", SimConfig(engine="mujoco", tyre_model="bullet"), ContactTuning(tyre_loop="compiled")) as w:
        assert w._fast is None  # no coulomb tyres, no tyre loop
    with pytest.raises(InputError, match=r"MuJoCoConfig.tyre_loop = 'numba' is not known; allowed: auto, compiled, python"):
        ContactTuning(tyre_loop="numba")
    with open_world(hm, "husky", SimConfig(engine="mujoco", mujoco=MuJoCoConfig(tyre_loop="python"))) as w:
        assert w._fast is None  # a study's [sim.mujoco] tyre_loop
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba now raises ImportError
    monkeypatch.delitem(sys.modules, "offroadbench.sim.engines.mujoco._tyres_c", raising=False)
    monkeypatch.delattr("offroadbench.sim.engines.mujoco._tyres_c", raising=False)
    with MuJoCoWorld(hm, "husky", MUJOCO) as w:
        assert w._fast is None
    with pytest.raises(InputError, match=r"MuJoCoConfig.tyre_loop = 'compiled' needs numba: pip install 'offroadbench\[fast\]'"):
        MuJoCoWorld(hm, "husky", MUJOCO, ContactTuning(tyre_loop="compiled"))


def test_the_compiled_loop_gives_the_python_rows_when_compiled_for_the_x86_64_baseline(tmp_path):
    """numba compiles for the host CPU (AVX-512 here, AVX2 on the project's other machines); compiled
    for the x86-64 baseline instead (no AVX, no FMA: ``NUMBA_CPU_NAME=x86-64``, a fresh cache) the
    loop gives the Python loop's row to the last bit: the result does not depend on the CPU's SIMD."""
    from tests.compiled_baseline import run_compiled_for_x86_64_baseline


    code = (
        "import numpy as np\n"
        "from offroadbench.heightmap import Heightmap\n"
        "from offroadbench.navigation.missions import Mission\n"
        "from offroadbench.sim import SimConfig, run_mission\n"
        "from offroadbench.sim.engines.mujoco.world import ContactTuning, MuJoCoWorld\n"
        "y, x = np.mgrid[0:81, 0:201] * 0.05\n"
        "hm = Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.03 * np.sin(5.3 * y + 0.7 * x), 0.05)\n"
        "with MuJoCoWorld(hm, 'husky', SimConfig(engine='mujoco'), ContactTuning(tyre_loop=LOOP)) as w:\n"
        "    assert (w._fast is not None) == (LOOP == 'compiled')\n"
        "    r, _ = run_mission(w, Mission.between(0, (2, 2), (8, 3)))\n"
        "print(repr(r))\n"
    )
    baseline = run_compiled_for_x86_64_baseline(code.replace("LOOP", "'compiled'"), tmp_path)
    ns = {}
    exec(code.replace("LOOP", "'python'").replace("print(repr(r))\n", ""), ns)
    assert baseline == repr(ns["r"]) + "\n" and "success=True" in baseline
