"""World: terrain placement, vehicle loading, spawn, clean-up and memory."""

import math
from pathlib import Path

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig, TrialWorld, VehicleSpec, World, list_vehicles, load_vehicle

CELL = 0.05


def _smooth_map(rows=121, cols=161):
    """Smooth, asymmetric terrain: z from 0.2 to ~1.4 m, so Bullet's (min+max)/2 centring matters."""
    y, x = np.mgrid[0:rows, 0:cols] * CELL
    z = 0.8 + 0.35 * np.sin(2 * np.pi * x / 4.0) + 0.25 * np.cos(2 * np.pi * y / 3.0) + 0.02 * x
    return Heightmap(z, CELL)


def test_terrain_sits_where_the_heightmap_says():
    hm = _smooth_map()
    rng = np.random.default_rng(0)
    with World(hm) as world:
        # grid nodes: exact
        for r, c in [(1, 1), (5, 150), (119, 3), (60, 80), (118, 158)]:
            assert world.ray_height(c * CELL, r * CELL) == pytest.approx(hm.z[r, c], abs=1e-5)
        # between nodes: the triangulated surface is within a few mm of the bilinear lookup
        x = rng.uniform(0.1, hm.width_m - 0.1, 200)
        y = rng.uniform(0.1, hm.height_m - 0.1, 200)
        ray = np.array([world.ray_height(a, b) for a, b in zip(x, y, strict=True)])
        assert np.abs(ray - hm.height_at(x, y)).max() < 3e-3


def test_settled_vehicle_rests_on_the_heightmap_surface():
    hm = _smooth_map()
    with World(hm) as world:
        world.spawn(4.0, 3.0, math.radians(30))
        # a rigid 4-wheeler on a curved ~30 deg surface rocks onto three or four wheels: the wheels
        # touching over the next 0.2 s
        touched, wheel_contacts = set(), []
        for _ in range(12):
            world.step()
            contacts = world.terrain_contacts()
            wheel_contacts = [c for c in contacts if c[3] in world.wheel_joints]
            touched |= {c[3] for c in wheel_contacts if c[9] > 0}
        assert len(touched) >= 3
        for c in wheel_contacts:
            px, py, pz = c[6]  # contact point on the terrain
            assert pz == pytest.approx(hm.height_at(px, py), abs=5e-3)
        # the chassis is level with the slope, not buried: base above the terrain under it
        (bx, by, bz), _, _, _ = world.base_state()
        assert 0.15 < bz - hm.height_at(bx, by) < 0.35


def test_vehicle_by_name_or_path_and_errors(tmp_path):
    assert "husky" in list_vehicles()
    spec = load_vehicle("husky")
    assert isinstance(spec, VehicleSpec) and Path(spec.urdf).is_file()
    assert spec.max_speed_m_s == 1.0 and spec.wheel_radius_m == 0.1651
    by_path = load_vehicle(Path(spec.urdf).parent / "vehicle.toml")
    assert by_path == spec
    with pytest.raises(InputError, match="unknown vehicle .*known: .*husky"):
        load_vehicle("tank")
    bad = tmp_path / "vehicle.toml"
    bad.write_text('[vehicle]\nname = "x"\nurdf = "missing.urdf"\n' + "\n".join(
        f"{k} = {v}" for k, v in {"left_wheel_joints": '["a"]', "right_wheel_joints": '["b"]', "wheel_radius_m": 0.1,
                                  "track_m": 0.5, "max_speed_m_s": 1, "max_accel_m_s2": 1, "max_jerk_m_s3": 1,
                                  "max_yaw_rate_rad_s": 1, "wheel_torque_limit_nm": 5, "wheel_friction": 0.8}.items()))
    with pytest.raises(InputError, match="not found"):
        load_vehicle(bad)


def test_urdf_has_real_masses_and_inertias():
    import pybullet as pb

    with World(Heightmap.flat(41, 41, CELL)) as world:
        cid, body = world.client_id, world.vehicle_id
        base = pb.getDynamicsInfo(body, -1, physicsClientId=cid)
        assert base[0] == pytest.approx(46.034)  # Clearpath's URDF
        assert base[2] == pytest.approx((0.6022, 1.7386, 2.0296), rel=1e-4)  # as written, not recomputed
        assert base[3][2] == pytest.approx(-0.0618)  # centre of mass below the box centre
        for j in world.wheel_joints:
            info = pb.getDynamicsInfo(body, j, physicsClientId=cid)
            assert info[0] == pytest.approx(2.637)
            assert info[2][0] == pytest.approx(0.02467, rel=1e-4)
            assert info[2][1] == pytest.approx(0.04411, rel=1e-4)  # the tyre's own: the drive train is geared
        # the drive train's inertia sits on grounded flywheels geared to the wheels (drivetrain.py)
        assert world.geometry.wheel_spin_inertia_kg_m2 == pytest.approx((world.spec.wheel_spin_inertia_kg_m2,) * 4)
    with World(Heightmap.flat(41, 41, CELL), sim=SimConfig(drive_train_reaction="link")) as world:
        for j in world.wheel_joints:  # the old model: all of it on the wheel link
            info = pb.getDynamicsInfo(world.vehicle_id, j, physicsClientId=world.client_id)
            assert info[2][1] == pytest.approx(world.spec.wheel_spin_inertia_kg_m2, rel=1e-4)


def test_vehicle_geometry_is_the_urdf_measured_once():
    """World.geometry (offroadbench.sim.engine.VehicleGeometry) against the Husky URDF's numbers:
    chassis box 0.9874 x 0.5709 x 0.2475 m centred on base_link, wheel axles 0.256 m fore/aft,
    0.2854 m to the side and 0.0910 m below base_link, chassis centre of mass 0.0618 m below it,
    tyre radius 0.1651 m, masses 46.034 + 4 x 2.637 kg."""
    with World(Heightmap.flat(41, 41, CELL)) as world:
        geo = world.geometry
        assert isinstance(world, TrialWorld)
    assert geo.mass_kg == pytest.approx(46.034 + 4 * 2.637)
    assert geo.wheel_spin_inertia_kg_m2 == pytest.approx((1.0,) * 4)  # the drive train of vehicle.toml
    for (x, y, z), (sx, sy) in zip(geo.wheel_centres_m, [(1, 1), (-1, 1), (1, -1), (-1, -1)], strict=True):
        assert (x, y, z) == pytest.approx((sx * 0.256, sy * 0.2854, -0.0910 + 0.0618), abs=1e-9)
    assert geo.wheelbase_m == pytest.approx(0.512)
    # bounding boxes carry Bullet's 1 mm collision margin on the box
    assert geo.length_m == pytest.approx(0.9874, abs=3e-3)
    assert geo.width_m == pytest.approx(2 * 0.2854 + 2 * 0.1651, abs=3e-3)
    assert geo.belly_m == pytest.approx(0.0910 + 0.1651 - 0.2475 / 2, abs=2e-3)
    assert geo.overhang  # the box reaches 0.49 m forward, the front tyres 0.256 + 0.165 = 0.42 m


def test_engine_reads_loads_centre_of_mass_and_gravity():
    """On flat ground the wheels carry the vehicle's weight; the centre of mass sits where the URDF
    puts it (0.189 m above the ground, less the tyres' sink); tilting gravity unloads the uphill side."""
    hm = Heightmap.flat(81, 81, CELL)
    with World(hm) as world:
        world.spawn(2.0, 2.0, 0.0)
        loads = world.wheel_loads_n()
        assert len(loads) == 4 and min(loads) > 0
        assert sum(loads) == pytest.approx(world.geometry.mass_kg * world.sim.gravity_m_s2, rel=0.05)
        assert world.centre_of_mass_m()[2] == pytest.approx(0.189, abs=0.005)
        g = world.sim.gravity_m_s2
        world.set_gravity(0.0, -g * math.sin(math.radians(20)), -g * math.cos(math.radians(20)))
        for _ in range(30):
            world.step()
        left, right = sum(world.wheel_loads_n()[:2]), sum(world.wheel_loads_n()[2:])
        assert left < right  # downhill toward -y: the right side carries more


def test_close_is_clean_and_idempotent():
    import pybullet as pb

    world = World(Heightmap.flat(41, 41, CELL))
    cid = world.client_id
    with world:
        assert pb.isConnected(physicsClientId=cid)
    assert not pb.isConnected(physicsClientId=cid)
    world.close()  # second close is a no-op


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    pytest.skip("no /proc/self/status")


def test_many_worlds_in_a_row_do_not_leak():
    hm = Heightmap(np.random.default_rng(0).uniform(0, 0.3, (301, 301)), CELL)
    with World(hm):
        pass
    before = _rss_mb()
    for _ in range(8):
        with World(hm) as world:
            world.spawn(7.0, 7.0, 0.0)
    grown = _rss_mb() - before
    # a leaked 301^2 heightfield costs ~50 MB (600 MB per 1009^2, shared/DESIGN.md); 8 would be ~400 MB
    assert grown < 40, f"RSS grew by {grown:.0f} MB over 8 worlds"


def test_sim_config_validation():
    with pytest.raises(InputError, match="telemetry_rate_hz"):
        SimConfig(physics_rate_hz=50, telemetry_rate_hz=20)
    with pytest.raises(InputError, match="physics_rate_hz"):
        SimConfig(physics_rate_hz=10)
    with pytest.raises(InputError, match="engine = 'bullet' is not known; allowed: .*pybullet"):
        SimConfig(engine="bullet")
    with pytest.raises(InputError, match="cone_friction"):
        SimConfig(cone_friction="yes")


def test_cone_friction_is_off_where_the_tyre_model_owns_the_friction():
    hm = Heightmap.flat(41, 41, CELL)
    for sim, cone in ((SimConfig(), False), (SimConfig(tyre_model="bullet"), True),
                      (SimConfig(cone_friction=True), True), (SimConfig(tyre_model="bullet", cone_friction=False), False)):
        with World(hm, "husky", sim) as world:
            assert world.cone_friction is cone


class _DirectBuildWorld(World):
    """The heightfield built straight from the data (pybullet's plain way, which keeps a render mesh)."""

    def _build_terrain(self) -> tuple[int, ...]:
        import pybullet as pb

        hm = self.hm
        shape = pb.createCollisionShape(
            pb.GEOM_HEIGHTFIELD, meshScale=[hm.cell_size_m, hm.cell_size_m, 1.0], heightfieldData=hm.z.ravel(),
            numHeightfieldRows=hm.cols, numHeightfieldColumns=hm.rows, physicsClientId=self._cid,
        )
        visual = pb.createVisualShape(pb.GEOM_SPHERE, radius=1e-3, physicsClientId=self._cid)
        centre = [hm.width_m / 2.0, hm.height_m / 2.0, (hm.z_min_m + hm.z_max_m) / 2.0]
        body = pb.createMultiBody(0, shape, visual, basePosition=centre, physicsClientId=self._cid)
        pb.changeDynamics(body, -1, lateralFriction=self.sim.terrain_friction, physicsClientId=self._cid)
        return (body,)


def test_empty_then_replaced_heightfield_drives_bit_for_bit_like_one_built_from_the_data(monkeypatch):
    """World builds its heightfield empty and writes the heights in place (no render mesh kept),
    with glibc's allocator tuned around the write; untiled, the collision shape, and so a
    rough-terrain trial, must be exactly the plain build's, with or without the allocator tuning."""
    import pybullet as pb

    from offroadbench.navigation.missions import Mission
    from offroadbench.sim import run_mission

    rng = np.random.default_rng(11)
    y, x = np.mgrid[0:121, 0:241] * CELL
    z = 0.5 + 0.2 * np.sin(x / 1.7) * np.cos(y / 2.3) + rng.uniform(0, 0.03, x.shape)
    hm = Heightmap(z, CELL)
    mission = Mission.between(0, (2.0, 3.0), (10.0, 3.5))
    results = []
    one_field = SimConfig(heightfield_tile_cells=0)
    for cls, lean_heap in ((World, True), (_DirectBuildWorld, False), (World, False)):
        with monkeypatch.context() as m:
            if not lean_heap:
                m.setattr("offroadbench.sim.engines.pybullet.heap._glibc", lambda: None)
            with cls(hm, sim=one_field) as world:
                (body,) = world.terrain_bodies
                aabb = pb.getAABB(body, physicsClientId=world.client_id)
                result, tel = run_mission(world, mission)
                results.append((aabb, result, tel["z_m"]))
    (aabb_a, res_a, z_a), *others = results
    for aabb_b, res_b, z_b in others:
        assert aabb_a == aabb_b
        assert res_a == res_b and np.array_equal(z_a, z_b)
    assert res_a.success and res_a.rms_pitch_rate_deg_s > 2.0  # it really drove over the rough map


@pytest.mark.parametrize("cells, tile", [(1008, 256), (1008, 252), (120, 16), (33, 16), (10, 16), (240, 0)])
def test_tile_spans_cover_the_map_with_shared_edges(cells, tile):
    from offroadbench.sim.config import tile_spans

    spans = tile_spans(cells, tile)
    assert spans[0][0] == 0 and spans[-1][1] == cells
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:], strict=False))  # neighbours share their edge sample (pairs: one fewer)
    sizes = [b - a for a, b in spans]
    assert min(sizes) >= 1 and max(sizes) - min(sizes) <= 1  # near-equal
    if tile:
        assert max(sizes) <= tile and len(spans) == -(-cells // tile)
    else:
        assert spans == [(0, cells)]


def test_tiled_terrain_is_the_same_surface_as_one_heightfield():
    """Tiles share their edge samples: vertical rays hit the same heights as on one heightfield,
    on the seams and between them, and no ray falls through a seam."""
    rng = np.random.default_rng(5)
    y, x = np.mgrid[0:121, 0:161] * CELL
    hm = Heightmap(0.5 + 0.3 * np.sin(x / 1.3) * np.cos(y / 0.9) + rng.uniform(0, 0.05, x.shape), CELL)
    from offroadbench.sim.config import tile_spans

    col_seams = np.array([b for _, b in tile_spans(hm.cols - 1, 32)[:-1]]) * CELL  # x of the seams
    row_seams = np.array([b for _, b in tile_spans(hm.rows - 1, 32)[:-1]]) * CELL  # y of the seams
    pts = [np.column_stack([rng.uniform(0.01, hm.width_m - 0.01, 300), rng.uniform(0.01, hm.height_m - 0.01, 300)]),
           np.column_stack([np.repeat(col_seams, 20), rng.uniform(0.01, hm.height_m - 0.01, 20 * len(col_seams))]),
           np.column_stack([rng.uniform(0.01, hm.width_m - 0.01, 20 * len(row_seams)), np.repeat(row_seams, 20)]),
           np.array([(cx, ry) for cx in col_seams for ry in row_seams])]  # tile corners
    pts = np.vstack(pts)
    heights = {}
    for tile in (0, 32):
        with World(hm, sim=SimConfig(heightfield_tile_cells=tile)) as world:
            assert len(world.terrain_bodies) == (1 if tile == 0 else 5 * 4)
            heights[tile] = np.array([world.ray_height(px, py) for px, py in pts])
    assert np.all(np.isfinite(heights[32]))
    np.testing.assert_allclose(heights[32], heights[0], atol=1e-9)


def test_vehicle_drives_across_tile_seams_as_on_one_heightfield():
    """On a tilted plane a wheel on a seam touches two heightfields; a 13 m drive across 16 seams
    must match the one-heightfield drive (same time, same height profile, no bumps)."""
    from offroadbench.navigation.missions import Mission
    from offroadbench.sim import run_mission

    y, x = np.mgrid[0:121, 0:321] * CELL
    hm = Heightmap(0.5 + 0.05 * x + 0.03 * y, CELL)  # 2.9 deg up along x, 1.7 deg across
    mission = Mission.between(0, (1.5, 3.0), (14.5, 3.2))
    runs = {}
    for tile in (0, 16):
        with World(hm, sim=SimConfig(heightfield_tile_cells=tile)) as world:
            runs[tile] = run_mission(world, mission)
    (res0, tel0), (res1, tel1) = runs[0], runs[16]
    assert res0.success and res1.success
    assert res1.traversal_time_s == pytest.approx(res0.traversal_time_s, abs=0.1)
    n = min(len(tel0["z_m"]), len(tel1["z_m"]))
    assert np.max(np.abs(tel1["z_m"][:n] - tel0["z_m"][:n])) < 5e-3
    assert res1.rms_vertical_accel_m_s2 < 1.5 * res0.rms_vertical_accel_m_s2 + 0.02
    assert res1.max_penetration_m < res0.max_penetration_m + 2e-3
