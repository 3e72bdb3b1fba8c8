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

import importlib
from dataclasses import dataclass
from typing import Any, Callable

from offroadbench.registry import Registry

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

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")


def _from_entry_point(name: str, obj: object) -> TerrainSpec:
    """An installed package's entry point names a :class:`TerrainSpec` (generator or modifier)."""
    if not isinstance(obj, TerrainSpec):
        raise TypeError(f"entry point {name!r} must name a TerrainSpec, got {type(obj).__name__}")
    return obj if obj.name == name else TerrainSpec(name, obj.kind, obj.config_cls, obj.fn, obj.summary)


#: every generator and modifier by name; installed packages add TerrainSpec objects through the
#: entry-point groups ``offroadbench.generators`` and ``offroadbench.modifiers``
TERRAIN_REGISTRY: Registry[TerrainSpec] = Registry(
    "terrain generator",
    entry_point_group=("offroadbench.generators", "offroadbench.modifiers"),
    loader=lambda: importlib.import_module("offroadbench.terrain"),  # importing it registers the built-ins
    adapt=_from_entry_point,
)


def register(name: str, config_cls: type, *, kind: str = "generator", summary: str = ""):
    """Decorator that adds a generator or modifier to the registry under ``name``."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")

    def deco(fn):
        TERRAIN_REGISTRY.add(name, TerrainSpec(name=name, kind=kind, config_cls=config_cls, fn=fn, summary=summary))
        return fn

    return deco


def get_spec(name: str) -> TerrainSpec:
    """The registry entry for ``name``; an unknown name suggests the closest known ones."""
    return TERRAIN_REGISTRY.get(name)
