"""Moore-neighbourhood gradient map (Eq. 3-4), classes, closing, border fractions."""

import numpy as np
import pytest

from offroadbench import Heightmap
from offroadbench.analysis.roughness import (
    HIGH,
    LOW,
    SEMI,
    RoughnessConfig,
    border_mask,
    class_fractions,
    classify,
    close_rough,
    gradient_map,
    paper_gradient_to_slope,
)


def test_threshold_conversion_from_paper_units():
    assert paper_gradient_to_slope(50) == pytest.approx(50 * 0.75 / 128)
    assert paper_gradient_to_slope(50) == pytest.approx(0.293, abs=5e-4)
    assert paper_gradient_to_slope(140) == pytest.approx(0.820, abs=5e-4)
    cfg = RoughnessConfig()
    assert cfg.low_max_slope == pytest.approx(0.29297, abs=1e-5)
    assert cfg.semi_max_slope == pytest.approx(0.82031, abs=1e-5)


def test_gradient_of_a_plane_is_its_steepest_neighbour_slope():
    h = 0.05
    y, x = np.mgrid[0:20, 0:20] * h
    hm = Heightmap(0.3 * x, h)
    g = gradient_map(hm)
    # along x the rise/run is 0.3; diagonal neighbours give 0.3*h/(h*sqrt2) = 0.212 < 0.3
    np.testing.assert_allclose(g, 0.3, rtol=1e-12)
    hm = Heightmap(0.3 * x + 0.4 * y, h)
    # diagonal (1,1): (0.3+0.4)*h / (h sqrt 2) = 0.495 > edge max 0.4
    np.testing.assert_allclose(gradient_map(hm)[1:-1, 1:-1], 0.7 / np.sqrt(2), rtol=1e-12)


def test_gradient_matches_literal_eq4_on_random_map(rng):
    z = rng.normal(size=(12, 9))
    hm = Heightmap(z, 0.05)
    g = gradient_map(hm)
    for r in range(12):
        for c in range(9):
            vals = []
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if (dr or dc) and 0 <= rr < 12 and 0 <= cc < 9:
                        vals.append(abs(z[r, c] - z[rr, cc]) / (0.05 * np.hypot(dr, dc)))
            assert g[r, c] == pytest.approx(max(vals), rel=1e-12)


def test_classes_follow_thresholds():
    h = 0.05
    x = np.arange(30) * h
    z = np.zeros((5, 30))
    # three zones with slopes 0.1, 0.5, 1.0 (edge-to-edge), separated by flat gaps
    z[:, :10] = 0.1 * x[:10]
    z[:, 10:20] = z[0, 9] + 0.5 * (x[10:20] - x[9])
    z[:, 20:] = z[0, 19] + 1.0 * (x[20:] - x[19])
    classes = classify(Heightmap(z, h))
    assert (classes[:, 1:9] == LOW).all()
    assert (classes[:, 11:19] == SEMI).all()
    assert (classes[:, 21:29] == HIGH).all()


def test_closing_fills_narrow_gaps_only():
    classes = np.zeros((40, 40), np.uint8)
    classes[10:30, 10:18] = HIGH
    classes[10:30, 20:28] = HIGH  # 2-pixel gap at cols 18-19
    closed = close_rough(classes, radius_m=0.15, cell_size_m=0.05)  # 3 px disk
    assert (closed[12:28, 18:20] == HIGH).all()
    assert (closed[:5] == LOW).all() and (closed[:, :5] == LOW).all()
    assert (closed[classes == HIGH] == HIGH).all()  # closing is extensive
    assert np.array_equal(close_rough(classes, 0.0, 0.05), classes)


def test_border_fraction_excludes_border():
    classes = np.full((101, 101), HIGH, np.uint8)
    classes[10:91, 10:91] = LOW  # exactly the part at >= 1.0 m from every edge at 0.1 m cells
    frac = class_fractions(classes, 0.1, border_m=1.0)
    assert frac == {"low": 1.0, "semi": 0.0, "high": 0.0}
    assert border_mask((101, 101), 1.0, 0.1).sum() == 81 * 81


def test_vectorised_on_paper_size(rng):
    hm = Heightmap(rng.normal(size=(1009, 1009)) * 0.01, 0.05)
    classes = classify(hm)
    assert classes.shape == (1009, 1009) and classes.dtype == np.uint8


@pytest.mark.parametrize("radius_px", [1.0, 1.5, 2.3, 5.0, 7.7])
def test_row_closing_is_scipys_binary_closing(rng, radius_px):
    """close_rough's closing by rows (roughness._disk_close) gives scipy's binary_closing pixel for
    pixel, at the map's edges too, for sparse, dense and blobby masks and for disks of any radius."""
    from scipy.ndimage import binary_closing, gaussian_filter

    from offroadbench.analysis.roughness import _disk_close, disk

    se = disk(radius_px)
    masks = [rng.random(shape) < p for p in (0.05, 0.3, 0.6, 0.95) for shape in ((40, 57), (13, 90), (2, 30))]
    masks.append(gaussian_filter(rng.random((150, 170)), 3) > 0.5)
    for mask in masks:
        np.testing.assert_array_equal(_disk_close(mask, se), binary_closing(mask, structure=se))


def test_row_closing_rejects_no_element_shape():
    """An element whose rows are not centred runs goes to scipy's own closing: the same pixels."""
    from scipy.ndimage import binary_closing

    from offroadbench.analysis.roughness import _disk_close, _row_runs

    se = np.array([[1, 0, 1], [1, 1, 1], [0, 1, 0]], dtype=bool)
    assert _row_runs(se) is None
    mask = np.random.default_rng(3).random((30, 30)) < 0.4
    np.testing.assert_array_equal(_disk_close(mask, se), binary_closing(mask, structure=se))
