"""16-bit PNG + sidecar: true 16-bit output, round-trip error, refusals, no partial files."""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from offroadbench import Heightmap, InputError
from offroadbench.io.png16 import read_png16, sidecar_path, ue_z_range_m, write_png16


@pytest.fixture
def hm(rng):
    return Heightmap(rng.normal(size=(37, 53)) * 0.7 + 2.0, 0.05)


def test_written_png_is_true_16_bit_with_full_range(tmp_path, hm):
    p = tmp_path / "t.png"
    meta = write_png16(hm, p, meta={"seed": 7, "recipe_name": "x"})
    with Image.open(p) as img:
        assert img.mode.startswith("I;16") or img.mode == "I"
        q = np.asarray(img)
        assert img.size == (53, 37)  # width = cols, height = rows: no transposition
        assert img.text["seed"] == "7"
        assert float(img.text["cell_size_m"]) == 0.05
    assert q.min() == 0 and q.max() == 65535
    assert np.unravel_index(np.argmax(q), q.shape) == np.unravel_index(np.argmax(hm.z), hm.z.shape)
    side = json.loads(sidecar_path(p).read_text())
    assert side["cell_size_m"] == 0.05 and side["z_min_m"] == hm.z_min_m and side["z_max_m"] == hm.z_max_m
    assert side["ue_scale_x"] == pytest.approx(5.0)
    # Unreal: level v at Location.Z + (v - 32768) / 128 * Scale.Z cm, so 65535 levels span relief exactly
    assert side["ue_scale_z"] == pytest.approx(hm.relief_m * 100 * 128 / 65535, rel=1e-15)
    assert side["ue_location_z_cm"] == pytest.approx(hm.z_min_m * 100 + 256 * side["ue_scale_z"], rel=1e-15)
    assert meta["seed"] == 7


def test_round_trip_within_half_step(tmp_path, hm):
    p = tmp_path / "t.png"
    write_png16(hm, p)
    back = read_png16(p)
    step = hm.relief_m / 65535
    assert np.max(np.abs(back.z - hm.z)) <= step / 2 + 1e-12
    assert back.cell_size_m == hm.cell_size_m
    assert back.z_min_m == hm.z_min_m and back.z_max_m == pytest.approx(hm.z_max_m, abs=1e-12)


def test_paper_ue_scale_for_paper_relief(tmp_path):
    """The paper's Z scale 0.75 spans 65535 / 128 * 0.75 cm = 3.83994 m; its 3.84 m relief needs 0.7500114."""
    z = np.zeros((5, 5))
    z[2, 2] = 3.84
    meta = write_png16(Heightmap(z, 0.05), tmp_path / "p.png")
    assert meta["ue_scale_z"] == pytest.approx(0.75, rel=2e-5) and meta["ue_scale_z"] != 0.75
    assert ue_z_range_m(meta["ue_scale_z"]) == pytest.approx(3.84, rel=1e-15)
    assert ue_z_range_m(100.0) == pytest.approx(511.9921875)  # the "-256..+256 m" at Z scale 100


def test_without_sidecar_uses_text_chunks_or_user_values(tmp_path, hm):
    p = tmp_path / "t.png"
    write_png16(hm, p)
    with_side = read_png16(p)
    os.remove(sidecar_path(p))
    assert np.array_equal(read_png16(p).z, with_side.z)
    # a foreign 16-bit PNG has neither: the user must give cell size and relief
    q = (np.arange(25).reshape(5, 5) * 1000).astype(np.uint16)
    Image.fromarray(q).save(tmp_path / "foreign.png")
    with pytest.raises(InputError, match="give the cell size"):
        read_png16(tmp_path / "foreign.png")
    back = read_png16(tmp_path / "foreign.png", cell_size_m=0.1, relief_m=65.535)
    np.testing.assert_allclose(back.z, q / 1000.0)


def test_refuses_8_bit_and_colour(tmp_path):
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "g8.png")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp_path / "rgb.png")
    with pytest.raises(InputError, match="8-bit grayscale PNG; a heightmap must be 16-bit"):
        read_png16(tmp_path / "g8.png")
    with pytest.raises(InputError, match="RGB colour PNG"):
        read_png16(tmp_path / "rgb.png")
    (tmp_path / "nope.png").write_bytes(b"hello")
    with pytest.raises(InputError, match="not a PNG"):
        read_png16(tmp_path / "nope.png")


def test_unwritable_path_leaves_nothing(tmp_path, hm, monkeypatch):
    with pytest.raises(InputError, match="does not exist"):
        write_png16(hm, tmp_path / "missing" / "t.png")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    if os.access(ro, os.W_OK):  # root ignores permissions: the check then sees what a user would
        real = os.access
        monkeypatch.setattr(os, "access", lambda p, mode, *a, **k: False if Path(p) == ro else real(p, mode, *a, **k))
    try:
        with pytest.raises(InputError, match="not writable"):
            write_png16(hm, ro / "t.png")
    finally:
        ro.chmod(0o700)
    assert list(tmp_path.rglob("*.png")) == []


def test_failure_mid_write_leaves_no_partial_file(tmp_path, hm, monkeypatch):
    import PIL.Image

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(PIL.Image.Image, "save", boom)
    with pytest.raises(RuntimeError):
        write_png16(hm, tmp_path / "t.png")
    assert list(tmp_path.iterdir()) == []


def test_flat_map_round_trip(tmp_path):
    hm = Heightmap.flat(4, 6, 0.5, z_m=3.0)
    write_png16(hm, tmp_path / "f.png")
    back = read_png16(tmp_path / "f.png")
    assert np.array_equal(back.z, hm.z)


def test_written_files_get_the_usual_mode(tmp_path, hm):
    old = os.umask(0o022)
    try:
        write_png16(hm, tmp_path / "m.png")
    finally:
        os.umask(old)
    assert (tmp_path / "m.png").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "m.json").stat().st_mode & 0o777 == 0o644
