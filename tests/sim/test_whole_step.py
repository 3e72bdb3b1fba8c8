"""The MuJoCo world's whole trial step in one compiled call (offroadbench.sim.engines.mujoco._tyres_c.
step_trial: MuJoCo's ``mj_step1`` / ``mj_step2`` called from numba with the tyre kernels between them)
against the Python loop and against the compiled kernels called between the bindings' MuJoCo calls:
the same bits."""

from __future__ import annotations

import numpy as np
import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, run_mission

pytest.importorskip("mujoco")
pytest.importorskip("numba")

from offroadbench.sim.engines.mujoco import _layout  # noqa: E402
from offroadbench.sim.engines.mujoco.settings import MuJoCoConfig  # noqa: E402
from offroadbench.sim.engines.mujoco.world import MuJoCoWorld  # noqa: E402

MUJOCO = SimConfig(engine="mujoco")
SOIL = SimConfig(engine="mujoco", tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=1.62)


def _rough_map() -> Heightmap:
    y, x = np.mgrid[0:81, 0:201] * 0.05
    return Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.03 * np.sin(5.3 * y + 0.7 * x), 0.05)


def _worlds(hm, sim=MUJOCO, **tuning):
    """(Python loop, compiled kernels between the bindings' calls, whole compiled step)."""
    python = MuJoCoWorld(hm, "husky", sim, MuJoCoConfig(tyre_loop="python", **tuning))
    glue = MuJoCoWorld(hm, "husky", sim, MuJoCoConfig(tyre_loop="compiled", **tuning))
    glue._fast_step = glue._fast_soil_step = glue._step_call = None
    whole = MuJoCoWorld(hm, "husky", sim, MuJoCoConfig(tyre_loop="compiled", **tuning))
    if sim.tyre_model == "terramechanics":
        assert python._fast_soil is None and glue._fast_soil is not None and whole._fast_soil_step is not None
    else:
        assert python._fast is None and glue._fast is not None and whole._fast_step is not None
    return python, glue, whole


@pytest.mark.parametrize("sim, tuning", [(MUJOCO, {}), (MUJOCO, {"tyres_each_substep": False}),
                                         (MUJOCO, {"hfield_collision": "mujoco"}), (MUJOCO, {"min_rate_hz": 240}),
                                         (SOIL, {}), (SOIL, {"tyres_each_substep": False})])
def test_the_whole_compiled_step_gives_the_python_loops_bits(sim, tuning):
    """Lockstep over rough ground, turning (every wheel slips), with base pushes, on the coulomb tyres
    and on lunar soil: after every trial step the three worlds' state, applied forces, loads and
    penetration (soil: sinkage) are equal to the bit."""
    worlds = _worlds(_rough_map(), sim, **tuning)
    try:
        for w in worlds:
            w.spawn(2.0, 2.0, 0.3)
        for t in range(200):
            for w in worlds:
                w.command_wheels(*((6.0, 2.0) if t < 100 else (-3.0, 4.0)))
                if t % 25 == 0:
                    w.push_base(0.0, 200.0, 50.0)
                w.step()
            ref = worlds[0]
            for w in worlds[1:]:
                assert np.array_equal(w.data.qpos, ref.data.qpos) and np.array_equal(w.data.qvel, ref.data.qvel), t
                assert np.array_equal(w.data.xfrc_applied, ref.data.xfrc_applied), t
                assert w.wheel_loads_n() == ref.wheel_loads_n() and w.wheel_penetration_m() == ref.wheel_penetration_m()
        assert np.abs(ref.data.xfrc_applied).max() > 10.0  # forces were applied
        if sim.tyre_model == "terramechanics":
            assert ref.wheel_penetration_m() > 0.0 and all(w.wheel_slip() == ref.wheel_slip() for w in worlds)
        else:
            assert min(sum(w.wheel_loads_n()) for w in worlds) > 0
    finally:
        for w in worlds:
            w.close()


def test_a_mission_row_is_the_same_with_the_whole_compiled_step():
    hm = _rough_map()
    rows = []
    for w in _worlds(hm):
        with w:
            r, tel = run_mission(w, Mission.between(0, (2, 2), (8, 3)))
            rows.append((repr(r), tel))
    assert "success=True" in rows[0][0]
    for row, tel in rows[1:]:
        assert row == rows[0][0]
        assert all(np.array_equal(tel[k], rows[0][1][k], equal_nan=True) for k in tel)


def test_the_step_layout_is_checked_on_a_probe_and_a_wrong_one_is_refused():
    lay = _layout.step_layout()
    assert lay is not None and lay.contact_size % 8 == 0
    assert _layout._probe_checks_out(lay)
    assert not _layout._probe_checks_out(_layout.StepLayout(**{**lay.__dict__, "efc_address": lay.efc_address - 4}))
    assert not _layout._probe_checks_out(_layout.StepLayout(**{**lay.__dict__, "ncon": lay.ncon + 4}))
