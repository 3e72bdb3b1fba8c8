"""What every engine shares, written once above the engine packages (engines/pybullet, engines/mujoco).

Nothing here imports a physics engine: these are the geometry and terrain facts each engine's
world uses the same way.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from offroadbench.heightmap import Heightmap

__all__ = ["max_height_near"]


def max_height_near(hm: Heightmap, x_m: float, y_m: float, radius_m: float) -> float:
    """Highest terrain sample in the square of half-side ``radius_m`` around (x, y), clipped to the
    map, metres (where every engine spawns a vehicle clear of the ground); ``z_max`` off the map."""
    c0 = max(0, int(math.floor((x_m - radius_m) / hm.cell_size_m)))
    c1 = min(hm.cols - 1, int(math.ceil((x_m + radius_m) / hm.cell_size_m)))
    r0 = max(0, int(math.floor((y_m - radius_m) / hm.cell_size_m)))
    r1 = min(hm.rows - 1, int(math.ceil((y_m + radius_m) / hm.cell_size_m)))
    if c0 > c1 or r0 > r1:
        return hm.z_max_m
    return float(hm.z[r0 : r1 + 1, c0 : c1 + 1].max())
