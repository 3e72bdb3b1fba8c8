"""Contract tests over every registered terrain generator and modifier (DESIGN.md):
shape, finite, same seed -> identical array, other seed -> different array, cfg unchanged."""

import pickle

import numpy as np
import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.terrain import TERRAIN_REGISTRY
from offroadbench.terrain.grid import GridConfig

ROWS, COLS, CELL = 65, 72, 0.25
GRID = GridConfig(rows=ROWS, cols=COLS, cell_size_m=CELL)


def _example_cfg(spec):
    """The default config, or for a layer that takes data (no file: generators read none), data in memory."""
    if spec.name == "dem":
        from offroadbench.io.dem import RawDEM

        y, x = np.mgrid[0:40, 0:50] * 0.5
        z = 0.3 * np.sin(x / 2.0) + 0.1 * y
        z[10:14, 20:25] = np.nan  # a gap to fill
        return spec.config_cls(dem=RawDEM(z=z, cell_size_m=0.5))
    return spec.config_cls()


def _base():
    y, x = np.mgrid[0:ROWS, 0:COLS] * CELL
    return Heightmap(0.2 * np.sin(x / 3.0) * np.cos(y / 4.0), CELL)


def _run(spec, cfg, seed):
    rng = np.random.default_rng(seed)
    if spec.kind == "modifier":
        return spec.fn(cfg, _base(), rng)
    return spec.fn(cfg, GRID, rng)


@pytest.mark.parametrize("name", sorted(TERRAIN_REGISTRY))
def test_generator_contract(name):
    spec = TERRAIN_REGISTRY.get(name)
    cfg = _example_cfg(spec)
    before = pickle.dumps(cfg)
    a = _run(spec, cfg, 1)
    b = _run(spec, cfg, 1)
    c = _run(spec, cfg, 2)
    assert isinstance(a, Heightmap)
    if spec.kind == "generator":
        assert a.shape == (ROWS, COLS) and a.cell_size_m == CELL
    assert np.isfinite(a.z).all()
    assert np.array_equal(a.z, b.z), "same seed must give a bit-identical terrain"
    assert not np.array_equal(a.z, c.z), "another seed must give another terrain"
    assert pickle.dumps(cfg) == before, "the config (and any data it holds) must not be mutated"
