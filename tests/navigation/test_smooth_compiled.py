"""The compiled Gaussian filter of seen_map (offroadbench.navigation._smooth_c) gives scipy's
numbers to the last bit, so the mast sensor's plans do not depend on whether numba is installed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

import offroadbench.navigation.perception as perception
from offroadbench.heightmap import Heightmap

pytest.importorskip("numba")


def _hex(a) -> list[str]:
    return [float(x).hex() for x in np.ravel(a)]


@pytest.mark.parametrize(("shape", "sigma"), [((121, 137), 20.0), ((40, 9), 6.5), ((5, 300), 3.0), ((64, 64), 0.7)])
def test_gaussian_nearest_is_scipys_to_the_bit(shape, sigma):
    from offroadbench.navigation._smooth_c import gaussian_nearest

    rng = np.random.default_rng(len(shape) + int(10 * sigma))
    seen = rng.random(shape) < 0.5
    for a in (seen.astype(float), np.where(seen, rng.normal(0.0, 0.4, shape), 0.0), rng.normal(0.0, 1.0, shape)):
        want = gaussian_filter(a, sigma, mode="nearest")
        got = gaussian_nearest(a, sigma)
        assert _hex(got) == _hex(want)
        assert not np.array_equal(want, a)  # a real filter


def test_seen_map_is_the_same_with_and_without_the_compiled_filter(monkeypatch):
    rng = np.random.default_rng(4)
    y, x = np.mgrid[0:121, 0:101] * 0.05
    hm = Heightmap(0.3 * np.sin(x / 1.3) + 0.2 * np.sin((x + y) / 0.9), 0.05)
    seen = ((x - 2.0) ** 2 + (y - 3.0) ** 2 < 4.0) & (rng.random(hm.shape) < 0.9)
    out = []
    for use in (True, False):
        monkeypatch.setattr(perception, "USE_COMPILED_SMOOTHING", use)
        out.append(perception.seen_map(hm, seen).z)
    assert _hex(out[0]) == _hex(out[1])
    assert not np.array_equal(out[0], hm.z)
