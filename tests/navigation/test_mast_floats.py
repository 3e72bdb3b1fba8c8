"""The mast sensor's scan, made cheaper (branch ``mastperf``), gives the bits of the form the
committed rows were recorded with: the viewshed (its work arrays kept from scan to scan, no
off-map ``np.where``, the visible samples taken once; or numba's sweep ray by ray,
offroadbench.navigation.compiled.sweep) and the scan's noise, odometry frame and
cell sums (written into work arrays term by term), each against its form at commit c822f5c on
random maps, positions, headings and drift, compared as float hex."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

import offroadbench.navigation.sensor as sensor
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.perception import PerceptionConfig
from offroadbench.navigation.sensor import MastSensor, viewshed


def _hex(values) -> list[str]:
    return [float(x).hex() for x in np.ravel(values)]


def _old_viewshed(hm, xy, sensor_z_m, range_m):
    """offroadbench.navigation.sensor.viewshed as written at c822f5c (one new array per step)."""
    cell = hm.cell_size_m
    n_r = max(1, int(range_m / cell))
    n_a = max(8, int(math.ceil(2.0 * math.pi * range_m / cell)))
    r = (np.arange(1, n_r + 1) * cell)[None, :]
    phi = (np.arange(n_a) * (2.0 * math.pi / n_a))[:, None]
    x = xy[0] + r * np.cos(phi)
    y = xy[1] + r * np.sin(phi)
    col, row = x / cell, y / cell
    on = (col >= 0) & (col <= hm.cols - 1) & (row >= 0) & (row <= hm.rows - 1)
    z = map_coordinates(hm.z, [row, col], order=1, mode="nearest")
    tan = (z - sensor_z_m) / r
    tan = np.where(on, tan, np.inf)
    horizon = np.maximum.accumulate(tan, axis=1)
    before = np.concatenate([np.full((n_a, 1), -np.inf), horizon[:, :-1]], axis=1)
    vis = on & (tan >= before - 1e-12) & np.cumprod(on, axis=1, dtype=bool)
    rr = np.broadcast_to(r, x.shape)
    return x[vis], y[vis], z[vis], rr[vis]


class _OldMast(MastSensor):
    """MastSensor with ``_scan`` as written at c822f5c."""

    def _scan(self, true_xy):
        cfg, hm = self.cfg, self.hm
        ground = hm.height_at(*np.clip(true_xy, 0.0, [hm.width_m, hm.height_m]))
        x, y, z, r = _old_viewshed(hm, true_xy, float(ground) + cfg.mast_height_m, cfg.sensor_range_m)
        z = z + cfg.sensor_noise_per_range * r * self.rng.standard_normal(z.shape)
        c, s = math.cos(self.heading_error), math.sin(self.heading_error)
        dx, dy = x - true_xy[0], y - true_xy[1]
        qx = self._belief[0] + c * dx - s * dy
        qy = self._belief[1] + s * dx + c * dy
        col = np.rint(qx / hm.cell_size_m).astype(np.int64)
        row = np.rint(qy / hm.cell_size_m).astype(np.int64)
        ok = (col >= 0) & (col < hm.cols) & (row >= 0) & (row < hm.rows)
        flat = row[ok] * hm.cols + col[ok]
        new = self.z.copy().ravel()
        if flat.size:
            lo = int(flat.min())
            sums = np.bincount(flat - lo, weights=z[ok])
            counts = np.bincount(flat - lo)
            hit = counts > 0
            new[lo:lo + len(counts)][hit] = sums[hit] / counts[hit]
        self.z = new.reshape(hm.shape)
        self.scans += 1
        self._scanned_at = true_xy.copy()


def _map(rng, rows, cols, cell):
    y, x = np.mgrid[0:rows, 0:cols] * cell
    z = 0.3 * np.sin(x / 1.3) + 0.2 * np.sin((x + y) / 0.9) + rng.normal(0.0, 0.05, (rows, cols))
    z[rng.random(z.shape) < 0.02] = 0.0
    return Heightmap(z, cell)


#: the numpy sweep, and numba's compiled one where numba is installed
PATHS = [False] + ([True] if sensor._compiled_sweep() is not None else [])


@pytest.mark.parametrize("compiled", PATHS)
def test_viewshed_gives_the_bits_of_its_earlier_form(compiled, monkeypatch):
    monkeypatch.setattr(sensor, "USE_COMPILED_SWEEP", compiled)
    rng, seen = np.random.default_rng(11), 0
    for rows, cols, cell in [(90, 110, 0.1), (121, 121, 0.05), (40, 30, 0.25)]:
        hm = _map(rng, rows, cols, cell)
        # inside, near an edge, on a corner, exactly on grid lines and off the map
        spots = [(rng.uniform(0, hm.width_m), rng.uniform(0, hm.height_m)) for _ in range(4)]
        spots += [(0.0, 0.0), (hm.width_m, 0.5 * hm.height_m), (3 * cell, 7 * cell), (-0.4, 1.0),
                  (hm.width_m + 0.3, hm.height_m + 0.2)]
        for range_m in (2.0, 3.3):
            for xy in spots:
                z0 = float(rng.uniform(-0.5, 1.5))
                got, want = viewshed(hm, xy, z0, range_m), _old_viewshed(hm, xy, z0, range_m)
                assert [_hex(a) for a in got] == [_hex(a) for a in want]
                seen += want[0].size
    assert seen > 10_000


@pytest.mark.parametrize("compiled", PATHS)
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("shape", [(101, 81), (201, 201)])
def test_mast_scans_build_the_bits_of_the_earlier_scan(seed, shape, compiled, monkeypatch):
    """Scans along a random drive (drift on, so the believed frame turns and shifts; the drive
    reaches the map's edges, so some samples fall off the believed map) build the same maps, with
    the same draws left in the stream, as the earlier scan."""
    monkeypatch.setattr(sensor, "USE_COMPILED_SWEEP", compiled)
    rng = np.random.default_rng(100 + seed)
    hm = _map(rng, *shape, 0.05)
    cfg = PerceptionConfig(sensor="mast", sensor_range_m=2.5, odometry_drift=0.05, scan_every_m=0.2)
    start = (rng.uniform(0.5, hm.width_m - 0.5), rng.uniform(0.5, hm.height_m - 0.5))
    new = MastSensor(hm, cfg, np.random.default_rng(seed), start, 0.3)
    old = _OldMast(hm, cfg, np.random.default_rng(seed), start, 0.3)
    pos, heading = np.array(start), rng.uniform(0, 2 * math.pi)
    for _ in range(120):
        heading += rng.normal(0.0, 0.3)
        pos = np.clip(pos + 0.07 * np.array([math.cos(heading), math.sin(heading)]), -0.2,
                      [hm.width_m + 0.2, hm.height_m + 0.2])
        assert new.update(pos, heading) == old.update(pos, heading)
        assert _hex(new.z) == _hex(old.z)
    assert new.scans == old.scans > 20
    assert new.rng.standard_normal() == old.rng.standard_normal()
    assert (~np.isnan(new.z)).sum() > 2000  # a real map was built
