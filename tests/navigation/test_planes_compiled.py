"""The compiled residual pass of the footprint hazard (offroadbench.navigation.compiled.planes) gives the
numpy pass's numbers to the last bit, so the planners' paths do not depend on whether numba is
installed."""

from __future__ import annotations

import numpy as np
import pytest

import offroadbench.navigation.costmap as costmap
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.recipe import load_terrain

pytest.importorskip("numba")


def _both(z, cell_m, radius_m, f, monkeypatch):
    shape = (-(-z.shape[0] // f), -(-z.shape[1] // f))
    out = []
    for use in (True, False):
        monkeypatch.setattr(costmap, "USE_COMPILED_PLANES", use)
        out.append(costmap._patch_planes(z, cell_m, radius_m, f, shape))
    return out


@pytest.mark.parametrize(("radius_m", "f"), [(0.55, 2), (0.3, 1), (0.7, 3)])
def test_residuals_are_the_numpy_pass_to_the_bit(radius_m, f, monkeypatch):
    hm = load_terrain("paper-d2.6", seed=11, overrides={"grid.rows": 121, "grid.cols": 137})[0]
    (g1, r1), (g0, r0) = _both(hm.z, hm.cell_size_m, radius_m, f, monkeypatch)
    assert np.array_equal(g1, g0) and np.array_equal(r1, r0)
    assert r0.shape == (-(-121 // f), -(-137 // f)) and r0.max() > 0.01  # a rough map: real residuals


def test_a_tilted_plane_has_no_residual_and_a_nan_propagates(monkeypatch):
    """On a plane the residual is rounding only (away from the edge padding); a NaN height inside a disk gives NaN there (as numpy's
    max does), and only there."""
    rows, cols = np.mgrid[0:40, 0:50] * 0.05
    z = 0.3 * cols - 0.2 * rows + 1.0
    (g1, r1), (g0, r0) = _both(z, 0.05, 0.25, 2, monkeypatch)
    inner = (slice(4, -4), slice(4, -4))  # disks clear of the edge padding
    assert np.array_equal(r1, r0) and r0[inner].max() < 1e-12 and np.allclose(g0[inner], np.hypot(0.3, 0.2))
    z[20, 25] = np.nan
    (_, r1), (_, r0) = _both(z, 0.05, 0.25, 2, monkeypatch)
    assert np.array_equal(np.isnan(r1), np.isnan(r0)) and np.isnan(r0).sum() > 0 and not np.isnan(r0).all()
    assert np.array_equal(r1[~np.isnan(r1)], r0[~np.isnan(r0)])


def test_the_hazard_of_a_believed_map_is_the_same_with_and_without_numba(monkeypatch):
    """The whole footprint hazard, on a map with a flat-filled corner (what the sensor's planner sees)."""
    from offroadbench.navigation.problem import VehicleEnvelope

    hm = load_terrain("paper-d2.45", seed=3, overrides={"grid.rows": 101, "grid.cols": 101})[0]
    z = hm.z.copy()
    z[:40, :40] = float(np.median(z))
    hm = Heightmap(z, hm.cell_size_m)
    veh = VehicleEnvelope()
    out = []
    for use in (True, False):
        monkeypatch.setattr(costmap, "USE_COMPILED_PLANES", use)
        out.append(costmap._footprint_hazard(hm, veh, 2))
    assert all(np.array_equal(out[0][k], out[1][k]) for k in out[0])
