"""Every export loaded by the tool that reads it: MuJoCo, rasterio (GDAL), usd-core, trimesh, and
Pillow + Unreal's documented 16-bit mapping. These packages are the ``[readers]`` extra, which the
README's test command (and so CI) installs; without them these tests skip.

Gazebo and Webots do not install from PyPI; their files are checked by the contract test through
strict readers of our own (ElementTree for SDF, :func:`offroadbench.io.export.webots.read_wbt`)."""

import re

import numpy as np
import pytest

from offroadbench import Heightmap
from offroadbench.io.export import export_heightmap


@pytest.fixture
def hm():
    """Non-square, far from z = 0, a distinct peak: any flip, transpose or offset shows."""
    rng = np.random.default_rng(11)
    z = rng.normal(size=(13, 21)) * 0.4 + 40.0
    z[9, 4] = 43.0
    return Heightmap(z, 0.07)


def test_mujoco_compiles_and_rays_hit_the_samples(hm, tmp_path):
    mujoco = pytest.importorskip("mujoco")
    export_heightmap(hm, "mujoco", tmp_path, name="t")
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "t.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.nhfield == 1 and (model.hfield_nrow[0], model.hfield_ncol[0]) == hm.shape
    top = hm.z_max_m + 1.0
    geomid = np.zeros(1, dtype=np.int32)
    hit = np.empty(hm.shape)
    eps = 1e-9  # the map's edges: a ray exactly on the boundary may miss the field
    for r in range(hm.rows):
        for c in range(hm.cols):
            x = min(max(c * hm.cell_size_m, eps), hm.width_m - eps)
            y = min(max(r * hm.cell_size_m, eps), hm.height_m - eps)
            dist = mujoco.mj_ray(model, data, np.array([x, y, top]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
            assert dist >= 0, (r, c)
            hit[r, c] = top - dist
    # float32 data and MuJoCo's float32 normalisation; edge samples moved by eps on slopes < 100
    assert np.max(np.abs(hit - hm.z)) < 1e-5 * hm.relief_m + 1e-7
    # nothing outside the map: just past each edge the rays miss
    for x, y in ((-1e-3, hm.height_m / 2), (hm.width_m + 1e-3, hm.height_m / 2), (hm.width_m / 2, -1e-3), (hm.width_m / 2, hm.height_m + 1e-3)):
        assert mujoco.mj_ray(model, data, np.array([x, y, top]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid) == -1


def test_rasterio_reads_transform_values_and_crs(hm, tmp_path):
    rasterio = pytest.importorskip("rasterio")
    export_heightmap(hm, "geotiff", tmp_path / "a", name="t")
    export_heightmap(hm, "geotiff", tmp_path / "b", name="t", meta={"crs": "IAU_2015:30110"})
    with rasterio.open(tmp_path / "a" / "t.geo.tif") as src:
        assert src.crs.to_wkt().startswith("LOCAL_CS") and 'UNIT["metre",1' in src.crs.to_wkt()  # no body, metres
        assert src.dtypes == ("float32",) and (src.height, src.width) == hm.shape
        assert src.res == (hm.cell_size_m, hm.cell_size_m)
        band = src.read(1)
        # the pixel holding z[r, c] has its centre at (c * cell, r * cell)
        for r, c in ((0, 0), (hm.rows - 1, hm.cols - 1), (9, 4), (2, 17)):
            x, y = src.xy(*src.index(c * hm.cell_size_m, r * hm.cell_size_m))
            assert (x, y) == pytest.approx((c * hm.cell_size_m, r * hm.cell_size_m), abs=1e-12)
            assert band[src.index(x, y)] == np.float32(hm.z[r, c])
        assert src.bounds.left == pytest.approx(-hm.cell_size_m / 2) and src.bounds.bottom == pytest.approx(-hm.cell_size_m / 2)
        assert src.tags()["AREA_OR_POINT"] == "Point"
    with rasterio.open(tmp_path / "b" / "t.geo.tif") as src:
        assert "Equirectangular" in src.crs.to_wkt() and "Moon" in src.crs.to_wkt()
        assert src.crs.linear_units == "metre"


def test_usd_core_opens_the_stage_with_collision(hm, tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom, UsdPhysics

    export_heightmap(hm, "usd", tmp_path, name="t")
    stage = Usd.Stage.Open(str(tmp_path / "t.usd"))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    prim = stage.GetDefaultPrim().GetChild("terrain")
    assert prim.IsA(UsdGeom.Mesh)
    assert prim.HasAPI(UsdPhysics.CollisionAPI) and prim.HasAPI(UsdPhysics.MeshCollisionAPI)
    assert UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get() == UsdPhysics.Tokens.none
    mesh = UsdGeom.Mesh(prim)
    pts = np.array(mesh.GetPointsAttr().Get(), dtype=np.float64)
    world = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
    pts = pts @ world[:3, :3] + world[3, :3]
    xx, yy = np.meshgrid(hm.x_coords_m(), hm.y_coords_m())
    assert np.allclose(pts[:, 0], xx.ravel(), rtol=0, atol=1e-6) and np.allclose(pts[:, 1], yy.ravel(), rtol=0, atol=1e-6)
    assert np.max(np.abs(pts[:, 2] - hm.z.ravel())) <= np.finfo(np.float32).eps * hm.relief_m
    counts = np.array(mesh.GetFaceVertexCountsAttr().Get())
    assert counts.size == 2 * (hm.rows - 1) * (hm.cols - 1) and np.all(counts == 3)
    # USD's own bound of the mesh is the map's extent and height range
    box = UsdGeom.Imageable(prim).ComputeWorldBound(Usd.TimeCode.Default(), UsdGeom.Tokens.default_).ComputeAlignedRange()
    assert tuple(box.GetMin()) == pytest.approx((0.0, 0.0, hm.z_min_m), abs=1e-5)
    assert tuple(box.GetMax()) == pytest.approx((hm.width_m, hm.height_m, hm.z_max_m), abs=1e-5)


def test_trimesh_loads_the_obj(hm, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    export_heightmap(hm, "obj", tmp_path, name="t")
    mesh = trimesh.load(tmp_path / "t.obj", process=False)
    xx, yy = np.meshgrid(hm.x_coords_m(), hm.y_coords_m())
    assert np.array_equal(mesh.vertices, np.stack([xx.ravel(), yy.ravel(), hm.z.ravel()], axis=1))
    assert len(mesh.faces) == 2 * (hm.rows - 1) * (hm.cols - 1)
    assert np.all(mesh.face_normals[:, 2] > 0)  # counter-clockwise from above
    assert mesh.bounds.tolist() == [[0.0, 0.0, hm.z_min_m], [hm.width_m, hm.height_m, hm.z_max_m]]
    # its projected area is the map's
    assert np.sum(mesh.area_faces * mesh.face_normals[:, 2]) == pytest.approx(hm.width_m * hm.height_m, rel=1e-12)


def test_unreal_mapping_on_the_png_and_the_written_scale(hm, tmp_path):
    from PIL import Image

    export_heightmap(hm, "unreal", tmp_path, name="t")
    text = (tmp_path / "t_unreal.txt").read_text()
    # the numbers a user types into the editor
    loc_z = float(re.search(r"Location \(cm\):.*Z (\S+)", text).group(1))
    sx, sy, sz = (float(v) for v in re.search(r"Scale:\s+X (\S+)\s+Y (\S+)\s+Z (\S+)", text).groups())
    with Image.open(tmp_path / "t.png") as img:
        assert img.mode.startswith("I;16") and img.size == (hm.cols, hm.rows)
        v = np.asarray(img).astype(np.float64)
    # Unreal: vertex (col c, row r) at (c * Scale.X, r * Scale.Y) cm, level v at Location.Z + (v - 32768) / 128 * Scale.Z cm
    assert sx == sy == 7.0
    z_ue = (loc_z + (v - 32768) / 128 * sz) / 100
    assert np.max(np.abs(z_ue - hm.z)) <= hm.relief_m / 65535 / 2 * (1 + 1e-6)
    assert np.unravel_index(np.argmax(z_ue), z_ue.shape) == (9, 4)
