"""Registry of terrain generators and modifiers, looked up by name.

Two kinds of entry:

* ``generator``: ``fn(cfg, grid, rng) -> Heightmap`` on the
  :class:`~offroadbench.terrain.grid.GridConfig` ``grid`` (a recipe's ``[grid]`` table). Pure: no
  I/O, no globals, randomness only from the ``np.random.Generator`` passed in.
* ``modifier``: ``fn(cfg, heightmap, rng) -> Heightmap``: works on an existing terrain
  (e.g. stamping craters, filling gaps, fractal expansion).

Register with the decorator::

    @register("wm", WMConfig, summary="3D Weierstrass-Mandelbrot surface (Majhor & Bos 2023, Eq. 1-2)")
    def generate_wm(cfg: WMConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap: ...
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from offroadbench.errors import InputError

__all__ = ["TerrainSpec", "register", "get_spec", "TERRAIN_REGISTRY"]

KINDS = ("generator", "modifier")


@dataclass(frozen=True)
class TerrainSpec:
    """One registry entry: its name, kind, config class, function and a one-line summary."""

    name: str
    kind: str
    config_cls: type
    fn: Callable[..., Any]
    summary: str = ""


TERRAIN_REGISTRY: dict[str, TerrainSpec] = {}


def register(name: str, config_cls: type, *, kind: str = "generator", summary: str = ""):
    """Decorator that adds a generator or modifier to the registry under ``name``."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")

    def deco(fn):
        if name in TERRAIN_REGISTRY:
            raise ValueError(f"terrain {kind} {name!r} is registered twice")
        TERRAIN_REGISTRY[name] = TerrainSpec(name=name, kind=kind, config_cls=config_cls, fn=fn, summary=summary)
        return fn

    return deco


def get_spec(name: str) -> TerrainSpec:
    """The registry entry for ``name``; an unknown name lists the known ones."""
    import offroadbench.terrain  # noqa: F401  (importing the package registers every generator)

    try:
        return TERRAIN_REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(TERRAIN_REGISTRY))
        raise InputError(f"unknown terrain generator {name!r}; known: {known}") from None
