"""Terrain generators. Importing this package registers every generator and modifier."""

from offroadbench.terrain import multifractal, wm  # noqa: F401
from offroadbench.terrain import craters  # noqa: F401
from offroadbench.terrain import fbm  # noqa: F401
from offroadbench.terrain import diamond_square  # noqa: F401
from offroadbench.terrain import enhance  # noqa: F401
from offroadbench.terrain.registry import TERRAIN_REGISTRY, get_spec, register

__all__ = ["TERRAIN_REGISTRY", "get_spec", "register"]
