import numpy as np
import pytest

from offroadbench import Heightmap, InputError


def test_geometry_and_convention():
    z = np.arange(12, dtype=float).reshape(3, 4)  # z[r, c] at x = c * h, y = r * h
    hm = Heightmap(z, 0.5)
    assert hm.shape == (3, 4)
    assert hm.width_m == 1.5 and hm.height_m == 1.0
    assert hm.extent_m == (0.0, 1.5, 0.0, 1.0)
    assert hm.height_at(1.0, 0.5) == z[1, 2]  # x = 1.0 -> col 2, y = 0.5 -> row 1
    assert hm.relief_m == 11.0


def test_bilinear_is_exact_on_a_plane():
    y, x = np.mgrid[0:5, 0:7] * 0.2
    hm = Heightmap(0.3 * x - 0.7 * y + 2.0, 0.2)
    xs = np.array([0.0, 0.13, 0.77, 1.2])
    ys = np.array([0.0, 0.41, 0.55, 0.8])
    np.testing.assert_allclose(hm.height_at(xs, ys), 0.3 * xs - 0.7 * ys + 2.0, atol=1e-12)


def test_immutable_copy():
    z = np.zeros((3, 3))
    hm = Heightmap(z, 1.0)
    z[0, 0] = 5.0
    assert hm.z[0, 0] == 0.0
    with pytest.raises(ValueError):
        hm.z[0, 0] = 1.0


@pytest.mark.parametrize(
    "z, cell, match",
    [
        (np.zeros((2, 5)), 1.0, "at least 3x3"),
        (np.zeros(9), 1.0, "2-D"),
        (np.array([[0, 0, 0], [0, np.nan, 0], [0, 0, 0]], float), 1.0, "NaN"),
        (np.full((3, 3), np.inf), 1.0, "NaN/inf"),
        (np.zeros((3, 3)), 0.0, "cell_size_m"),
        (np.zeros((3, 3)), -1.0, "cell_size_m"),
    ],
)
def test_validation(z, cell, match):
    with pytest.raises(InputError, match=match):
        Heightmap(z, cell)


def test_height_at_outside_raises(flat_map):
    with pytest.raises(InputError, match="outside the map"):
        flat_map.height_at(-0.5, 0.0)
    assert flat_map.height_at(flat_map.width_m, flat_map.height_m) == 1.5


def test_rescaled():
    hm = Heightmap(np.array([[1.0, 2.0, 3.0]] * 3), 1.0).rescaled(6.0)
    assert hm.z_min_m == 0.0 and hm.z_max_m == 6.0
