"""Exporters, format by format: each simulator's own placement rules put every sample where the
Heightmap says, on non-square maps and edge cases the contract test (tests/contracts/
test_exporters.py) does not cover. These tests re-implement each simulator's documented mapping
from file to world (cited in offroadbench/io/export/<format>.py); tests/io/test_export_readers.py
loads the files with the real tools."""

import importlib.util
import json
import logging
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from PIL import Image

from offroadbench import Heightmap, InputError
from offroadbench.cli import main
from offroadbench.io import export as ex
from offroadbench.io.export import EXPORTERS, export_heightmap
from offroadbench.io.export import _staging as staging
from offroadbench.io.export._staging import os as staging_os
from offroadbench.io.export.gazebo import gazebo_grid_size
from offroadbench.io.export.grid import read_grid
from offroadbench.io.png16 import ue_heights_m, ue_landscape_settings

SMALL = ["--set", "grid.rows=33", "--set", "grid.cols=33"]


@pytest.fixture
def hm(rng):
    """Non-square, off-zero heights, a distinct maximum: any flip or transpose shows."""
    z = rng.normal(size=(9, 14)) * 0.3 + 5.0
    z[2, 11] = 7.5
    return Heightmap(z, 0.25)


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def listing(d):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*"))


# --------------------------------------------------------------------------- registry
def test_unknown_format_suggests_and_lists_the_known_ones(hm, tmp_path):
    with pytest.raises(InputError, match="unknown export format 'gazbo'; did you mean 'gazebo'") as err:
        export_heightmap(hm, "gazbo", tmp_path / "o")
    assert ", ".join(EXPORTERS.names()) in str(err.value)
    assert not (tmp_path / "o").exists()


def test_option_for_another_format_and_bad_name_are_refused(hm, tmp_path):
    with pytest.raises(InputError, match="takes no option stride"):
        export_heightmap(hm, "tiff", tmp_path / "o", stride=2)
    with pytest.raises(InputError, match="export name"):
        export_heightmap(hm, "npy", tmp_path / "o", name="../escape")
    assert listing(tmp_path) == []


# --------------------------------------------------------------------------- obj
def read_obj(path):
    verts, faces = [], []
    for line in path.read_text().splitlines():
        if line.startswith("v "):
            verts.append([float(t) for t in line.split()[1:]])
        elif line.startswith("f "):
            faces.append([int(t) for t in line.split()[1:]])
    return np.array(verts), np.array(faces) - 1


def test_obj_vertices_are_exactly_the_samples_and_faces_point_up(hm, tmp_path):
    export_heightmap(hm, "obj", tmp_path, name="t")
    v, f = read_obj(tmp_path / "t.obj")
    rr, cc = np.meshgrid(np.arange(hm.rows), np.arange(hm.cols), indexing="ij")
    assert v.shape == (hm.rows * hm.cols, 3)
    assert np.array_equal(v[:, 2], hm.z.ravel())  # bit-exact heights
    assert np.array_equal(v[:, 0], cc.ravel() * hm.cell_size_m)
    assert np.array_equal(v[:, 1], rr.ravel() * hm.cell_size_m)
    assert len(f) == 2 * (hm.rows - 1) * (hm.cols - 1)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    normals = np.cross(b - a, c - a)
    assert np.all(normals[:, 2] > 0)  # counter-clockwise from above
    # the triangles tile the map: their projected areas add up to the extent
    assert 0.5 * normals[:, 2].sum() == pytest.approx(hm.width_m * hm.height_m)


def test_obj_stride_keeps_samples_and_extent(hm, tmp_path):
    export_heightmap(hm, "obj", tmp_path, name="t", stride=4)
    v, f = read_obj(tmp_path / "t.obj")
    rows, cols = [0, 4, 8], [0, 4, 8, 12, 13]  # the last row / column are always kept
    assert np.array_equal(v[:, 2], hm.z[np.ix_(rows, cols)].ravel())
    assert v[:, 0].max() == hm.width_m and v[:, 1].max() == hm.height_m
    assert len(f) == 2 * 2 * 4
    with pytest.raises(InputError, match="stride"):
        export_heightmap(hm, "obj", tmp_path / "x", stride=0)


# --------------------------------------------------------------------------- tiff / npy
def test_tiff_round_trips_float32_exactly(hm, tmp_path):
    export_heightmap(hm, "tiff", tmp_path, name="t", meta={"seed": 3})
    with Image.open(tmp_path / "t.tif") as img:
        assert img.mode == "F" and img.size == (hm.cols, hm.rows)
    back = read_grid(tmp_path / "t.tif")
    assert np.array_equal(back.z, hm.z.astype(np.float32).astype(np.float64))
    assert np.max(np.abs(back.z - hm.z)) <= np.finfo(np.float32).eps * np.abs(hm.z).max()
    assert back.cell_size_m == hm.cell_size_m
    side = json.loads((tmp_path / "t.tif.json").read_text())
    assert side["dtype"] == "float32" and side["seed"] == 3 and side["z_max_m"] == hm.z_max_m


def test_npy_round_trips_bit_exact(hm, tmp_path):
    export_heightmap(hm, "npy", tmp_path, name="t")
    assert np.array_equal(np.load(tmp_path / "t.npy"), hm.z)
    back = read_grid(tmp_path / "t.npy")
    assert np.array_equal(back.z, hm.z) and back.cell_size_m == hm.cell_size_m


def test_formats_share_a_directory_without_clobbering(hm, tmp_path):
    from offroadbench.io.png16 import read_png16

    for fmt in ("unreal", "tiff", "npy"):
        export_heightmap(hm, fmt, tmp_path, name="t")
    assert np.array_equal(read_grid(tmp_path / "t.npy").z, hm.z)
    assert np.max(np.abs(read_png16(tmp_path / "t.png").z - hm.z)) <= hm.relief_m / 65535
    assert json.loads((tmp_path / "t.json").read_text())["format"] == "offroadbench-png16/1"


# --------------------------------------------------------------------------- mujoco
def test_mujoco_hfield_reproduces_extent_relief_and_heights(hm, tmp_path):
    export_heightmap(hm, "mujoco", tmp_path, name="t")
    root = ET.parse(tmp_path / "t.xml").getroot()
    hf = root.find("asset/hfield")
    geom = root.find("worldbody/geom")
    assert geom.get("type") == "hfield" and geom.get("hfield") == hf.get("name")
    rx, ry, ez, base = map(float, hf.get("size").split())
    px, py, pz = map(float, geom.get("pos").split())
    assert 2 * rx == pytest.approx(hm.width_m) and 2 * ry == pytest.approx(hm.height_m)
    assert ez == pytest.approx(hm.relief_m) and base > 0
    raw = (tmp_path / hf.get("file")).read_bytes()
    nrow, ncol = np.frombuffer(raw[:8], dtype="<i4")
    assert (nrow, ncol) == hm.shape and len(raw) == 4 * (2 + nrow * ncol)
    data = np.frombuffer(raw[8:], dtype="<f4").reshape(nrow, ncol).astype(np.float64)
    # MuJoCo: normalise to [0, 1]; column c at x = c * 2 rx / (ncol - 1) - rx, row r at y = r * 2 ry / (nrow - 1) - ry
    norm = (data - data.min()) / (data.max() - data.min())
    world_z = pz + norm * ez
    c = np.arange(ncol)
    r = np.arange(nrow)
    world_x = px + c * 2 * rx / (ncol - 1) - rx
    world_y = py + r * 2 * ry / (nrow - 1) - ry
    assert world_x[0] == pytest.approx(0, abs=1e-12) and world_y[0] == pytest.approx(0, abs=1e-12)
    assert world_x[-1] == pytest.approx(hm.width_m) and world_y[-1] == pytest.approx(hm.height_m)
    assert np.allclose(world_x, hm.x_coords_m()) and np.allclose(world_y, hm.y_coords_m())
    assert np.max(np.abs(world_z - hm.z)) < 1e-6 * max(1.0, np.abs(hm.z).max())
    assert (world_z[0, 0], world_z[-1, -1]) == pytest.approx((hm.z[0, 0], hm.z[-1, -1]), abs=1e-5)


# --------------------------------------------------------------------------- gazebo
def gazebo_world(model_dir, name):
    """World (x, y, z) grids of a Gazebo heightmap model: image column j -> +x, image row i -> -y
    (the top row is the +y edge), level / 65535 * size.z above pos.z, centred on pos."""
    sdf = ET.parse(model_dir / "model.sdf").getroot()
    hmap = sdf.find("model/link/collision/geometry/heightmap")
    assert hmap.find("uri").text == f"model://{name}/materials/textures/{name}_heightmap.png"
    size = np.array(hmap.find("size").text.split(), dtype=float)
    pos = np.array(hmap.find("pos").text.split(), dtype=float)
    with Image.open(model_dir / "materials" / "textures" / f"{name}_heightmap.png") as img:
        assert img.mode in ("I;16", "I;16B", "I")
        q = np.asarray(img).astype(np.float64)
    n = q.shape[0]
    assert q.shape == (n, n) and n == gazebo_grid_size(n, n)
    j = np.arange(n)
    x = pos[0] - size[0] / 2 + j * size[0] / (n - 1)
    y = pos[1] + size[1] / 2 - j * size[1] / (n - 1)  # image row i
    z = pos[2] + q / 65535 * size[2]
    return x, y, z


def test_gazebo_grid_size():
    assert [gazebo_grid_size(n, n) for n in (3, 5, 6, 9, 10, 1009, 1025)] == [3, 5, 9, 9, 17, 1025, 1025]
    assert gazebo_grid_size(7, 13) == 17


def test_gazebo_square_map_is_placed_exactly(rng, tmp_path):
    z = rng.normal(size=(17, 17)) + 2.0
    z[3, 12] = 6.0
    hm = Heightmap(z, 0.5)
    export_heightmap(hm, "gazebo", tmp_path, name="g")
    x, y, zw = gazebo_world(tmp_path / "g", "g")
    # image row i is at y[i]: sample (0, 0) is the bottom-left pixel, the far corner the top-right one
    assert (x[0], y[-1]) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert (x[-1], y[0]) == pytest.approx((hm.width_m, hm.height_m))
    step = hm.relief_m / 65535
    assert abs(zw[-1, 0] - hm.z[0, 0]) <= step and abs(zw[0, -1] - hm.z[-1, -1]) <= step
    assert np.max(np.abs(zw[::-1] - hm.z)) <= step / 2 + 1e-12
    i, j = np.unravel_index(np.argmax(zw), zw.shape)
    assert (x[j], y[i]) == pytest.approx((12 * 0.5, 3 * 0.5))  # the peak is where the Heightmap has it
    config = ET.parse(tmp_path / "g" / "model.config").getroot()
    assert config.find("name").text == "g" and "used as they are" in config.find("description").text


def test_gazebo_non_square_map_is_resampled_over_the_same_extent(hm, tmp_path, caplog):
    with caplog.at_level(logging.INFO, logger="offroadbench.io.export.gazebo"):
        export_heightmap(hm, "gazebo", tmp_path, name="g")
    assert "resampled 9x14 -> 17x17 (bilinear" in caplog.text
    assert "extent is not square" in caplog.text  # classic Gazebo would render it square
    description = ET.parse(tmp_path / "g" / "model.config").getroot().find("description").text
    assert "resampled 9x14 -> 17x17 (bilinear" in description
    x, y, zw = gazebo_world(tmp_path / "g", "g")
    assert (x[0], y[-1]) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert (x[-1], y[0]) == pytest.approx((hm.width_m, hm.height_m))
    xx, yy = np.meshgrid(x, y)
    expected = hm.height_at(np.clip(xx, 0, hm.width_m), np.clip(yy, 0, hm.height_m))
    assert np.max(np.abs(zw - expected)) <= hm.relief_m / 65535
    assert abs(zw[-1, 0] - hm.z[0, 0]) <= hm.relief_m / 65535  # corners survive resampling
    assert abs(zw[0, -1] - hm.z[-1, -1]) <= hm.relief_m / 65535


# --------------------------------------------------------------------------- unreal
def test_unreal_scale_and_location_reproduce_heights(hm, tmp_path):
    export_heightmap(hm, "unreal", tmp_path, name="u")
    text = (tmp_path / "u_unreal.txt").read_text()
    s = ue_landscape_settings(hm)
    assert f"Z {s['location_z_cm']!r}" in text and f"Z {s['scale_z']!r}" in text and "1009" in text and "2017" in text
    assert s["scale_x"] == s["scale_y"] == 25.0
    assert s["scale_z"] == pytest.approx(hm.relief_m * 100 * 128 / 65535, rel=1e-15)
    with Image.open(tmp_path / "u.png") as img:
        q = np.asarray(img).astype(np.float64)
    assert q.shape == hm.shape  # pixel (r, c) = z[r, c]: X = columns, Y = rows, as Unreal reads it
    # Unreal: level v at Location.Z + (v - 32768) / 128 * Scale.Z cm, written out here once more by hand
    ue_z_m = (s["location_z_cm"] + (q - 32768) / 128 * s["scale_z"]) / 100
    assert np.array_equal(ue_z_m, ue_heights_m(q, s["scale_z"], s["location_z_cm"]))
    step = hm.relief_m / 65535
    assert np.max(np.abs(ue_z_m - hm.z)) <= step / 2 * (1 + 1e-9)  # the PNG's own quantisation, nothing more
    assert (ue_z_m.min(), ue_z_m.max()) == pytest.approx((hm.z_min_m, hm.z_max_m), abs=1e-12)
    side = json.loads((tmp_path / "u.json").read_text())
    assert side["ue_scale_z"] == s["scale_z"] and side["ue_location_z_cm"] == s["location_z_cm"]


def test_unreal_paper_scale_and_size_warning(tmp_path, caplog):
    z = np.add.outer(np.linspace(0, 1.92, 127), np.linspace(0, 1.92, 127))  # a 3.84 m ramp: no spire
    with caplog.at_level(logging.WARNING, logger="offroadbench.io.export.unreal"):
        res = export_heightmap(Heightmap(z, 0.05), "unreal", tmp_path / "a", name="p")
    # the paper's 3.84 m at Z scale 0.75: Unreal's exact scale is 384 * 128 / 65535 = 0.7500114...
    assert ue_landscape_settings(Heightmap(z, 0.05))["scale_z"] == pytest.approx(384 * 128 / 65535, rel=1e-15)
    assert "not one of" not in caplog.text and not any("warning" in n for n in res.notes)
    with caplog.at_level(logging.WARNING, logger="offroadbench.io.export.unreal"):
        res = export_heightmap(Heightmap(z[:100, :100], 0.05), "unreal", tmp_path / "b", name="p")
    assert "100x100 is not one of Unreal's recommended Landscape sizes" in caplog.text
    assert "not one of" in (tmp_path / "b" / "p_unreal.txt").read_text()


# --------------------------------------------------------------------------- atomic output
@pytest.fixture
def failing_exporter(monkeypatch):
    def write(hm, d, name, meta):
        (d / f"{name}.part").write_text("half")
        (d / "sub").mkdir()
        (d / "sub" / "x").write_text("half")
        raise InputError("boom")

    entry = ex.Exporter(name="broken", summary="fails half way", reader="none", write=write, read=None, precision_m=None)
    monkeypatch.setitem(EXPORTERS._entries, "broken", entry)


def test_failure_leaves_no_new_directory(hm, tmp_path, failing_exporter):
    with pytest.raises(InputError, match="boom"):
        export_heightmap(hm, "broken", tmp_path / "out", name="t")
    assert listing(tmp_path) == []


def test_failure_leaves_existing_directory_as_it_was(hm, tmp_path, failing_exporter):
    export_heightmap(hm, "npy", tmp_path, name="t")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*")}
    with pytest.raises(InputError, match="boom"):
        export_heightmap(hm, "broken", tmp_path, name="t")
    assert {p: p.read_bytes() for p in tmp_path.rglob("*")} == before


def test_failed_move_into_existing_directory_is_rolled_back(hm, tmp_path, monkeypatch):
    real_replace = os.replace
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(staging_os, "replace", flaky)
    monkeypatch.setattr(staging, "_exchange", lambda a, b: False)  # the file-by-file fallback
    with pytest.raises(OSError, match="No space left"):
        export_heightmap(hm, "gazebo", tmp_path, name="g")
    assert listing(tmp_path) == []


def test_failed_move_restores_the_files_it_replaced(hm, tmp_path, monkeypatch):
    export_heightmap(hm, "gazebo", tmp_path, name="g")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    real_replace = os.replace
    calls = []

    def flaky(src, dst):  # calls: set aside old png, move new png, set aside old config, move new config
        calls.append(dst)
        if len(calls) == 4:
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(staging_os, "replace", flaky)
    monkeypatch.setattr(staging, "_exchange", lambda a, b: False)  # the file-by-file fallback
    with pytest.raises(OSError, match="No space left"):
        export_heightmap(hm.with_z(hm.z * 2), "gazebo", tmp_path, name="g")
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_file_in_the_way_of_a_directory_is_an_input_error(hm, tmp_path):
    (tmp_path / "g").write_text("mine")
    with pytest.raises(InputError, match="is a file already"):
        export_heightmap(hm, "gazebo", tmp_path, name="g")
    assert listing(tmp_path) == ["g"] and (tmp_path / "g").read_text() == "mine"


def test_unwritable_output_is_an_input_error(hm, tmp_path, failing_exporter):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="not a directory"):
        export_heightmap(hm, "npy", blocker / "out")
    with pytest.raises(InputError, match="exists and is not a directory"):
        export_heightmap(hm, "npy", blocker)
    assert listing(tmp_path) == ["file"]
    # the one output-path policy (offroadbench.io.outputs): missing parents are created ...
    res = export_heightmap(hm, "npy", tmp_path / "missing" / "out")
    assert res.files and all(p.is_file() for p in res.files)
    # ... and removed again when the export fails
    with pytest.raises(InputError, match="boom"):
        export_heightmap(hm, "broken", tmp_path / "gone" / "deeper" / "out")
    assert not (tmp_path / "gone").exists() and (tmp_path / "missing" / "out").is_dir()


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write to read-only directories")
def test_read_only_directory_is_an_input_error(hm, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(InputError, match="cannot write into"):
            export_heightmap(hm, "npy", ro)
    finally:
        ro.chmod(0o700)


# --------------------------------------------------------------------------- CLI
def test_cli_list(capsys):
    code, out, _ = run(capsys, "export", "--list")
    assert code == 0
    for name in EXPORTERS:
        assert f"  {name}" in out


def test_cli_preset_to_mujoco_and_png_to_npy(tmp_path, capsys):
    code, out, err = run(capsys, "export", "paper-d2.45", "--seed", "2", "--format", "mujoco", "-o", str(tmp_path / "m"), *SMALL)
    assert code == 0, err
    assert (tmp_path / "m" / "paper-d2.45_seed2.xml").is_file() and "hfield size" in out
    png = tmp_path / "t.png"
    assert run(capsys, "generate", "paper-d2.45", "--seed", "2", "-o", str(png), *SMALL)[0] == 0
    code, out, err = run(capsys, "export", str(png), "--format", "npy", "-o", str(tmp_path / "n"))
    assert code == 0, err
    from offroadbench.io.png16 import read_png16

    assert np.array_equal(np.load(tmp_path / "n" / "t.npy"), read_png16(png).z)
    side = json.loads((tmp_path / "n" / "t.npy.json").read_text())
    assert side["source"] == str(png)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["paper-d2.45", "--format", "fbx"], "unknown export format 'fbx'"),
        (["paper-d2.45", "--format", "tiff", "--stride", "2"], "--stride applies to the obj format only"),
        (["paper-d2.45", "--format", "npy", "--name", "a/b"], "export name"),
        (["no-such-preset", "--format", "npy"], "no-such-preset"),
        (["paper-d2.45", "--format", "npy", "--set", "grid.rows=0"], "rows"),
    ],
)
def test_cli_bad_input_exit_2_and_no_output(tmp_path, capsys, argv, message):
    out_dir = tmp_path / "o"
    code, out, err = run(capsys, "export", *argv, "-o", str(out_dir))
    assert code == 2
    assert message in err and err.count("\n") == 1
    assert not out_dir.exists()


def test_cli_unwritable_directory_exit_2(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    code, _, err = run(capsys, "export", "paper-d2.45", "--format", "npy", "-o", str(tmp_path / "f" / "o"), *SMALL)
    assert code == 2 and "not a directory" in err
    assert listing(tmp_path) == ["f"]


def _spire_png(tmp_path):
    from offroadbench.io.png16 import write_png16

    y, x = np.mgrid[0:40, 0:40] * 0.05
    z = 0.6 + 0.2 * np.sin(3 * x) * np.cos(2 * y)
    z[0, 0] = 3.84  # one corner sample holds most of the relief, as on the paper presets
    write_png16(Heightmap(z, 0.05), tmp_path / "spire.png")
    return tmp_path / "spire.png", z


def test_cli_export_warns_about_a_spire_and_clips_on_request(tmp_path, capsys, caplog):
    png, z = _spire_png(tmp_path)
    with caplog.at_level(logging.WARNING, logger="offroadbench.cli.export"):  # the CLI warns, not the library
        code, out, err = run(capsys, "export", str(png), "--format", "npy", "-o", str(tmp_path / "a"))
    assert code == 0, err
    assert "top 0.1 % of samples span" in caplog.text and "--clip-percentile" in caplog.text
    assert "top 0.1 %" not in out  # printed once: as the logged warning, not again on stdout (issue 20)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="offroadbench.cli.export"):
        code, out, err = run(capsys, "export", str(png), "--format", "npy", "-o", str(tmp_path / "b"), "--clip-percentile", "0.1")
    assert code == 0, err
    assert "span" not in caplog.text and "warning" not in out
    clipped = np.load(tmp_path / "b" / "spire.npy")
    source = np.load(tmp_path / "a" / "spire.npy")
    assert clipped.max() == pytest.approx(np.percentile(source, 99.9)) and clipped.max() < 1.0
    lo, hi = np.percentile(source, [0.1, 99.9])
    keep = (source >= lo) & (source <= hi)
    assert np.array_equal(clipped[keep], source[keep]) and keep.sum() >= 0.997 * source.size
    assert json.loads((tmp_path / "b" / "spire.npy.json").read_text())["clip_percentile"] == 0.1


def test_cli_bad_clip_percentile_is_exit_2_before_any_work(tmp_path, capsys):
    png, _ = _spire_png(tmp_path)
    code, _, err = run(capsys, "export", str(png), "--format", "npy", "-o", str(tmp_path / "o"), "--clip-percentile", "50")
    assert code == 2 and "--clip-percentile 50.0 is out of range; allowed: 0 <= P < 50" in err
    assert not (tmp_path / "o").exists()


def test_text_numbers_are_exact_and_free_of_float_noise(tmp_path):
    """200 samples at 0.05 m span 9.95 m: 199 * 0.05 is 9.950000000000001 in float64, but the files
    say 9.95 (the decimal extent, one rounding) and every number reads back as the double written."""
    import re

    z = np.add.outer(np.linspace(0.1, 0.3, 9), np.linspace(0.0, 0.7, 200))  # 9 x 200 at 0.05 m
    hm = Heightmap(z, 0.05)
    # the exporters' extent is the decimal one (span_m), not the float product with its noise
    from offroadbench.io.export._common import half_span_m, span_m

    assert span_m(200, 0.05) == 9.95 and half_span_m(200, 0.05) == 4.975 and span_m(9, 0.05) == 0.4
    export_heightmap(hm, "mujoco", tmp_path, name="m")
    export_heightmap(hm, "gazebo", tmp_path, name="g")
    export_heightmap(hm, "webots", tmp_path, name="w")
    export_heightmap(hm, "unreal", tmp_path, name="u")
    hf = ET.parse(tmp_path / "m.xml").getroot().find("asset/hfield")
    assert hf.get("size").split()[:2] == ["4.975", "0.2"]
    size = ET.parse(tmp_path / "g" / "model.sdf").getroot().find("model/link/collision/geometry/heightmap/size").text
    assert size.split()[:2] == ["9.95", "0.4"]
    wbt = (tmp_path / "w.wbt").read_text()
    assert "xSpacing 0.05" in wbt and "(x 0..9.95, y 0..0.4)" in wbt
    noise = re.compile(r"\d\.\d*(0000000|9999999)\d")  # geometry only: the heights are whatever the data are
    for text in [(tmp_path / "m.xml").read_text(), (tmp_path / "g" / "model.sdf").read_text()]:
        assert not noise.search(text), noise.search(text).group(0)
    for text in [(tmp_path / "m.xml").read_text(), (tmp_path / "g" / "model.sdf").read_text(), wbt, (tmp_path / "u_unreal.txt").read_text()]:
        for token in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", text):
            assert repr(float(token)) == token or token.endswith(".0")  # the shortest text of its double


def test_every_format_shares_a_directory_with_every_other(tmp_path):
    """All formats under one name in one directory: no file of one is overwritten by another."""
    z = np.add.outer(np.linspace(0, 1, 17), np.linspace(0, 2, 17))
    hm = Heightmap(z, 0.1)
    written = {}
    for fmt in EXPORTERS.names():
        if all(importlib.util.find_spec(m) for m in EXPORTERS.get(fmt).requires):
            written[fmt] = export_heightmap(hm, fmt, tmp_path, name="t").files
    paths = [p for files in written.values() for p in files]
    assert len(paths) == len(set(paths)), "two formats write the same file"
