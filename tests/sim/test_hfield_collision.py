"""The MuJoCo world's compiled height-field collision functions (offroadbench.sim.engines.mujoco.
_hfield_c, ``[sim.mujoco] hfield_collision``) against MuJoCo's own ``mjc_ConvexHField``: every contact
of the wheels and the chassis with a cratered paper terrain, in thousands of random vehicle poses."""

from __future__ import annotations

import ctypes
import sys

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, run_mission

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("numba")

from offroadbench.sim.engines.mujoco import _hfield_c, _layout  # noqa: E402
from offroadbench.sim.engines.mujoco.settings import MuJoCoConfig  # noqa: E402
from offroadbench.sim.engines.mujoco.world import MuJoCoWorld  # noqa: E402
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe  # noqa: E402

MUJOCO = SimConfig(engine="mujoco")
#: closed-form sphere contacts against MuJoCo's GJK/EPA ones, for wheels at most DEEP_M into the ground
#: (measured: dist and pos to ~1e-15 m, normals to ~1e-10; EPA stops at ccd_tolerance 1e-6, which
#: bounds its normal's error to ~sqrt(1e-6 / r) only in deep overlaps)
DIST_TOL_M, POS_TOL_M, NORMAL_TOL = 1e-12, 1e-9, 1e-7
DEEP_M = 0.03


@pytest.fixture(scope="module")
def cratered():
    recipe = apply_overrides(load_recipe("multifractal-cratered"), {"grid.rows": 161, "grid.cols": 161})
    return generate_terrain(recipe, 3)


@pytest.fixture(scope="module")
def world(cratered):
    w = MuJoCoWorld(cratered, "husky", MUJOCO, MuJoCoConfig(hfield_collision="closed_form"))
    yield w
    w.close()


def _contacts(w):
    m, d = w.model, w.data
    mujoco.mj_kinematics(m, d)
    mujoco.mj_collision(m, d)
    c = d.contact
    return d.ncon, c.geom.copy(), c.dist.copy(), c.pos.copy(), c.frame.copy()


def _clearance_m(w, geoms) -> float:
    """Lowest gap between ``geoms`` and the terrain, by vertical rays (m; < 0: below the surface)."""
    m, d = w.model, w.data
    mujoco.mj_kinematics(m, d)
    up = 10.0
    gaps = []
    for g in geoms:
        c, r = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3)
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE:
            points = [(c, float(m.geom_size[g][0]))]
        else:  # a 5 x 5 grid over the box's lowest face
            size = m.geom_size[g]
            k = int(np.argmax(np.abs(r[2])))
            sign = -np.sign(r[2, k])
            a, b = [j for j in range(3) if j != k]
            points = [(c + r[:, k] * sign * size[k] + r[:, a] * u * size[a] + r[:, b] * v * size[b], 0.0)
                      for u in np.linspace(-1, 1, 5) for v in np.linspace(-1, 1, 5)]
        for p, below in points:
            ray = mujoco.mj_rayHfield(m, d, w._terrain_geom, np.array([p[0], p[1], p[2] + up]), np.array([0.0, 0.0, -1.0]))
            if ray >= 0:
                gaps.append(ray - up - below)
    return min(gaps)


def _random_poses(w, rng, n, rim_cells):
    """``n`` vehicle poses (free-joint qpos), each lowered until its wheels or, in every third pose,
    its chassis box reach into the terrain by up to 3 cm; half of them on crater rims."""
    hm = w.hm
    wheels = list(w._wheel_geom)
    box = [g for g in range(w.model.ngeom) if w.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
           and w.model.geom_bodyid[g] == w._chassis]
    for k in range(n):
        if k % 2 and len(rim_cells):
            r, c = rim_cells[rng.integers(len(rim_cells))]
            x, y = c * hm.cell_size_m, r * hm.cell_size_m
        else:
            x, y = rng.uniform(1.0, hm.width_m - 1.0), rng.uniform(1.0, hm.height_m - 1.0)
        yaw, roll, pitch = rng.uniform(-np.pi, np.pi), rng.normal(0, 0.15), rng.normal(0, 0.15)
        quat = np.zeros(4)
        mujoco.mju_euler2Quat(quat, np.array([roll, pitch, yaw]), "XYZ")
        w.data.qpos[0:3] = (x, y, hm.z_max_m + 1.0)
        w.data.qpos[3:7] = quat
        ref = box if k % 3 == 0 else wheels
        w.data.qpos[2] -= _clearance_m(w, ref) + rng.uniform(-0.005, DEEP_M)
        yield k


def _rim_cells(hm, share=0.02):
    """Grid cells of the sharpest convex curvature (crater rims on a cratered map), away from the edges."""
    z = hm.z
    lap = 4 * z[1:-1, 1:-1] - z[:-2, 1:-1] - z[2:, 1:-1] - z[1:-1, :-2] - z[1:-1, 2:]
    cut = np.quantile(lap, 1 - share)
    rows, cols = np.nonzero(lap >= cut)
    keep = (rows > 25) & (rows < hm.rows - 27) & (cols > 25) & (cols < hm.cols - 27)
    return np.stack([rows[keep] + 1, cols[keep] + 1], axis=1)


def test_contacts_equal_mujocos_own_in_random_poses_with_grounded_chassis_and_crater_rims(world, cratered):
    """2,400 poses: the same contacts in the same order; the chassis box's to the bit (its early-out
    only skips calls that MuJoCo would answer with none); the sphere wheels' to DIST_TOL_M, POS_TOL_M
    in position and NORMAL_TOL in the contact frame where no wheel is deeper than DEEP_M."""
    rng = np.random.default_rng(41)
    hf = world._hfield
    assert hf is not None
    m = world.model
    box_geoms = {g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX}
    counts = {"box": 0, "sphere": 0, "rim": 0, "grounded": 0}
    worst = np.zeros(3)
    for k in _random_poses(world, rng, 2400, _rim_cells(cratered)):
        want = _contacts(world)
        hf.install()
        try:
            got = _contacts(world)
        finally:
            hf.restore()
        assert got[0] == want[0], (k, got[0], want[0])
        n = want[0]
        assert np.array_equal(got[1], want[1]), k
        on_box = np.array([bool(set(p) & box_geoms) for p in want[1]], dtype=bool)
        for field in (2, 3, 4):
            assert np.array_equal(got[field][on_box], want[field][on_box]), (k, field)
        sphere = ~on_box
        counts["box"] += int(on_box.sum())
        counts["sphere"] += int(sphere.sum())
        counts["grounded"] += bool(on_box.any())
        counts["rim"] += bool(k % 2 and n)
        if sphere.any() and -want[2][sphere].min() <= DEEP_M:
            err = (np.abs(got[2][sphere] - want[2][sphere]).max(), np.abs(got[3][sphere] - want[3][sphere]).max(),
                   np.abs(got[4][sphere] - want[4][sphere]).max())
            worst = np.maximum(worst, err)
            assert err[0] <= DIST_TOL_M and err[1] <= POS_TOL_M and err[2] <= NORMAL_TOL, (k, err)
    assert counts["sphere"] > 5000 and counts["box"] > 300 and counts["grounded"] > 300 and counts["rim"] > 600, counts


def _plain_model():
    xml = ('<mujoco><asset><hfield name="h" nrow="9" ncol="9" size="1 1 0.2 0.1"/></asset><worldbody>'
           '<geom type="hfield" hfield="h"/><body pos="0.1 0.2 0.25"><freejoint/><geom type="sphere" size="0.15"/></body>'
           '<body pos="-0.3 0 0.21"><freejoint/><geom type="box" size="0.3 0.2 0.05"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    m.hfield_data[:] = np.random.default_rng(3).random(81).astype(np.float32)
    return m, mujoco.MjData(m)


def test_the_table_holds_mujocos_functions_outside_the_worlds_own_calls(cratered):
    """A plain model in the same process, stepped before, between and after a closed-form world's steps,
    gets MuJoCo's own contacts: the table's entries are MuJoCo's again after each of the world's calls."""
    g = mujoco.mjtGeom
    slots = _layout.table_slot_addresses(((g.mjGEOM_HFIELD, g.mjGEOM_SPHERE), (g.mjGEOM_HFIELD, g.mjGEOM_BOX)))
    entries = [ctypes.c_void_p.from_address(a).value for a in slots]
    m, d = _plain_model()
    mujoco.mj_forward(m, d)
    before = (d.ncon, d.contact.dist.copy(), d.contact.pos.copy(), d.contact.frame.copy())
    assert before[0] >= 2
    with MuJoCoWorld(cratered, "husky", MUJOCO, MuJoCoConfig(hfield_collision="closed_form")) as w:
        w.spawn(4.0, 4.0, 0.5)
        for _ in range(5):
            w.command_wheels(3.0, 3.0)
            w.step()
            assert [ctypes.c_void_p.from_address(a).value for a in slots] == entries
            mujoco.mj_forward(m, d)
            assert d.ncon == before[0]
            for got, want in zip((d.contact.dist, d.contact.pos, d.contact.frame), before[1:], strict=True):
                assert np.array_equal(got, want)
        w._hfield.install()
        try:  # the world's own functions are in the table while it steps
            assert [ctypes.c_void_p.from_address(a).value for a in slots] != entries
        finally:
            w._hfield.restore()
    assert [ctypes.c_void_p.from_address(a).value for a in slots] == entries


def _mission_rows(hm, mode):
    sim = SimConfig(engine="mujoco", mujoco=MuJoCoConfig(hfield_collision=mode))
    with MuJoCoWorld(hm, "husky", sim) as w:
        assert (w._hfield is None) == (mode == "mujoco")
        return run_mission(w, Mission.between(0, (2.0, 2.0), (6.5, 5.5)))


def test_exact_mode_gives_the_rows_of_mujocos_own_collision(cratered):
    """A mission over the cratered map: ``exact`` (the box's early-out only) gives MuJoCo's own row and
    telemetry to the bit; ``closed_form`` drives the same mission too (it may differ in the last bits)."""
    ref, ref_tel = _mission_rows(cratered, "mujoco")
    got, tel = _mission_rows(cratered, "exact")
    assert repr(got) == repr(ref)
    assert all(np.array_equal(tel[k], ref_tel[k], equal_nan=True) for k in ref_tel)
    closed, _ = _mission_rows(cratered, "closed_form")
    assert closed.success == ref.success and abs(closed.path_length_m - ref.path_length_m) < 1e-3


def test_the_setting_is_checked_and_without_numba_the_world_uses_mujocos_own(cratered, monkeypatch):
    with pytest.raises(InputError, match="MuJoCoConfig.hfield_collision = 'gjk' is not known"):
        MuJoCoConfig(hfield_collision="gjk")
    hm = cratered
    with MuJoCoWorld(hm, "husky", MUJOCO, MuJoCoConfig(hfield_collision="mujoco")) as w:
        assert w._hfield is None
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba now raises ImportError
    monkeypatch.delitem(sys.modules, "offroadbench.sim.engines.mujoco._hfield_c", raising=False)
    monkeypatch.delattr("offroadbench.sim.engines.mujoco._hfield_c", raising=False)
    with MuJoCoWorld(hm, "husky", MUJOCO, MuJoCoConfig(hfield_collision="closed_form")) as w:
        assert w._hfield is None


def test_a_layout_that_does_not_check_out_keeps_mujocos_own(world):
    """The struct offsets are checked against the world's arrays: a wrong one gives no layout."""
    layout = _layout.layout_for(world.model, world.data)
    assert layout is not None
    bad = _layout.Layout(model={**layout.model, "geom_size": layout.model["geom_size"] + 8}, data=layout.data,
                         precontact_size=layout.precontact_size)
    assert not _layout._checks_out(bad, world.model, world.data)
    assert _hfield_c.MODES == ("mujoco", "exact", "closed_form")
