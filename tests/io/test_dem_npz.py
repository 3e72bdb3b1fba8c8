"""Geographic .npz DEMs (matplotlib's layout): non-square cells in metres, rows south first."""

from __future__ import annotations

import numpy as np
import pytest

from offroadbench import InputError
from offroadbench.io.dem import EARTH_RADIUS_M, read_dem


def _write(path, z, *, lat_first=60.0, lat_last=59.9, **extra):
    data = {"elevation": z, "dx": 0.001, "dy": 0.001, "xmin": 10.0, "ymin": lat_first, "ymax": lat_last}
    data.update(extra)
    np.savez(path, **data)
    return path


def test_cells_are_metres_of_longitude_and_latitude_at_the_middle_latitude(tmp_path):
    z = np.arange(12, dtype=np.int16).reshape(3, 4)
    raw = read_dem(_write(tmp_path / "n.npz", z))  # first row the northern one (60 N): flipped
    deg = np.pi / 180
    assert raw.row_step_m == pytest.approx(EARTH_RADIUS_M * 0.001 * deg)  # 111.2 m
    assert raw.cell_size_m == pytest.approx(raw.row_step_m * np.cos(59.95 * deg))  # half of it at 60 N
    assert raw.cell_size_m == pytest.approx(0.5 * raw.row_step_m, rel=2e-3)
    np.testing.assert_array_equal(raw.z, z[::-1])
    assert raw.lon_lat_deg == (10.0, 59.9) and raw.gap_count == 0
    south_first = read_dem(_write(tmp_path / "s.npz", z, lat_first=59.9, lat_last=60.0))
    np.testing.assert_array_equal(south_first.z, z)  # already south first: as stored


def test_square_dems_keep_one_cell_size(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros((3, 3)))
    raw = read_dem(tmp_path / "a.npy", cell_size_m=0.5)
    assert raw.cell_size_y_m is None and raw.row_step_m == 0.5


@pytest.mark.parametrize("bad, match", [
    ({"dx": -0.001}, "dx = -0.001"),
    ({"elevation": np.zeros(5)}, "2-D numeric array"),
])
def test_bad_geographic_dems_are_input_errors(tmp_path, bad, match):
    z = bad.pop("elevation", np.zeros((3, 3)))
    with pytest.raises(InputError, match=match):
        read_dem(_write(tmp_path / "b.npz", z, **bad))


def test_a_missing_array_is_named(tmp_path):
    np.savez(tmp_path / "m.npz", elevation=np.zeros((3, 3)), dx=0.001)
    with pytest.raises(InputError, match="missing dy, xmin, ymin, ymax"):
        read_dem(tmp_path / "m.npz")
