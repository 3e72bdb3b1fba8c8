"""The memory model of a MuJoCo trial worker (offroadbench.memory.world_bytes, engine ``mujoco``):
an upper bound of a real worker's peak, with numba's compiled kernels counted."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from offroadbench.memory import (MUJOCO_ARENA_BYTES, MUJOCO_BYTES_PER_CELL, MUJOCO_WORKER_BASE_BYTES,
                                 NUMBA_KERNELS_BYTES, WORKER_BYTES_PER_CELL, world_bytes)

WORKER = """
import numpy as np
from pathlib import Path
from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig, open_world
rows = {rows}
y, x = np.mgrid[0:rows, 0:rows] * 0.05
hm = Heightmap(1.0 + 0.3 * np.sin(0.9 * x) * np.cos(0.7 * y), 0.05)
with open_world(hm, "husky", SimConfig(engine="mujoco")) as w:
    assert (w._fast is not None) == {numba}
    w.spawn(rows * 0.025, rows * 0.025, 0.0)
    for _ in range(120):
        w.command_wheels(3.0, 3.0)
        w.step()
hwm = [l for l in Path("/proc/self/status").read_text().splitlines() if l.startswith("VmHWM:")][0]
print(int(hwm.split()[1]) * 1024)
"""


def test_the_mujoco_estimate_counts_numba_and_the_cells_and_pybullets_is_unchanged():
    n = 1009 * 1009
    with_numba = world_bytes(1009, 1009, 256, engine="mujoco", numba=True)
    without = world_bytes(1009, 1009, 256, engine="mujoco", numba=False)
    assert with_numba - without == NUMBA_KERNELS_BYTES
    assert without == MUJOCO_WORKER_BASE_BYTES + MUJOCO_ARENA_BYTES + (WORKER_BYTES_PER_CELL + MUJOCO_BYTES_PER_CELL) * n
    assert world_bytes(1009, 1009, 256, engine="mujoco", numba=True) == world_bytes(1009, 1009, 0, engine="mujoco", numba=True)
    assert world_bytes(1009, 1009, 256) == world_bytes(1009, 1009, 256, engine="pybullet")
    with pytest.raises(ValueError, match="engine 'bullet' is not one of pybullet, mujoco"):
        world_bytes(9, 9, 0, engine="bullet")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")
def test_a_mujoco_worker_peaks_below_its_estimate():
    """A fresh process that builds a 513^2 MuJoCo world and drives it peaks below world_bytes (numba's
    kernels included where numba is installed); the estimate is not loose by more than half."""
    pytest.importorskip("mujoco")
    try:
        import numba  # noqa: F401
        has_numba = True
    except ImportError:
        has_numba = False
    rows = 513
    out = subprocess.run([sys.executable, "-c", WORKER.format(rows=rows, numba=has_numba)], capture_output=True,
                         text=True, check=True)
    peak = int(out.stdout.strip().splitlines()[-1])
    estimate = world_bytes(rows, rows, 0, engine="mujoco")
    assert peak <= estimate, (peak, estimate)
    assert peak > 0.5 * estimate, (peak, estimate)
    assert np.isfinite(peak)
