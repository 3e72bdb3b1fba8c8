"""Terrain generators and modifiers. Importing this package registers every one of them."""

from offroadbench.terrain.fractal import fbm, multifractal, rmd, spectral, wm  # noqa: F401
from offroadbench.terrain import craters, dem  # noqa: F401
from offroadbench.terrain.registry import TERRAIN_REGISTRY, get_spec, register

__all__ = ["TERRAIN_REGISTRY", "get_spec", "register"]
