"""Soil maps: which soil lies under each sample of a terrain (issue 47).

A recipe's ``[soil]`` table names the default soil and may vary it over the map::

    [soil]
    name = "lunar-regolith"                  # the default, everywhere nothing else applies
    raster = "soils.png"                     # optional: a PNG of soil indices aligned with the heights
    raster_soils = ["lunar-regolith", "snow"]  # index -> soil of the raster (required with raster)

    [[soil.regions]]                         # applied in file order, each painting over the last
    soil = "soft-crater-floor"               # a soil name or .toml path
    in_crater = true                         # inside a crater of the recipe's population ...
    crater_radius_fraction = 0.6             # ... within this fraction of its radius (the floor)
    crater_min_diameter_m = 2.0              # ... of at least this diameter

    [[soil.regions]]
    soil = "lete-sand"
    slope_max_deg = 5.0                      # rules over the terrain's own features: slope band ...
    height_max_m = 0.5                       # ... and height band (metres of the generated map)

    [[soil.regions]]
    soil = "snow"
    centre_m = [10.0, 12.0]                  # a patch: a disc (centre_m, radius_m) ...
    radius_m = 3.0
    # x_range_m = [0, 5], y_range_m = [2, 4] # ... or a rectangle

Every condition a region gives must hold for a sample to take its soil (a region with a patch and
a slope band is the steep part of the patch). The map's samples are the heightmap's (``index[r, c]``
is the soil at ``z[r, c]``); the tyre model reads the soil at the nearest sample to each wheel's
contact point each step (offroadbench.sim.tyre_laws.soil_wheels).

Slope: the gradient by central differences (``numpy.gradient``: one-sided at the border), compared
with ``tan`` of the thresholds, so no angle is computed per sample. Craters: the recipe's own
population (offroadbench.terrain.craters.layer.recipe_craters, the same random streams as the
terrain), centres and diameters in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = ["SOIL_KEYS", "REGION_KEYS", "SoilMap", "SoilMapConfig", "SoilRegion", "build_soil_map",
           "soil_map_config", "soil_map_for"]

#: keys of a recipe's ``[soil]`` table
SOIL_KEYS = ("name", "regions", "raster", "raster_soils")
#: keys of one ``[[soil.regions]]`` table
REGION_KEYS = ("soil", "slope_min_deg", "slope_max_deg", "height_min_m", "height_max_m", "in_crater",
               "crater_radius_fraction", "crater_min_diameter_m", "centre_m", "radius_m", "x_range_m", "y_range_m")


def _pair(value: Any, key: str, where: str) -> tuple[float, float] | None:
    if value is None:
        return None
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise InputError(f"{where}: {key} = {value!r}; must be two finite numbers (metres)")
    return float(value[0]), float(value[1])


@dataclass(frozen=True, kw_only=True)
class SoilRegion:
    """One region of a soil map: a soil and the conditions a sample must meet to take it."""

    soil: str
    """The region's soil: a name (soils/*.toml) or a .toml path."""
    slope_min_deg: float | None = None
    """Samples at least this steep, degrees (None: no lower bound)."""
    slope_max_deg: float | None = None
    """Samples at most this steep, degrees (None: no upper bound)."""
    height_min_m: float | None = None
    """Samples at least this high, m (the generated map's heights)."""
    height_max_m: float | None = None
    """Samples at most this high, m."""
    in_crater: bool = False
    """Samples inside a crater of the recipe's population (within ``crater_radius_fraction`` of its radius)."""
    crater_radius_fraction: float = 1.0
    """How far out from a crater's centre ``in_crater`` reaches, as a fraction of its rim radius (0, 1.5]."""
    crater_min_diameter_m: float = 0.0
    """``in_crater`` counts craters at least this wide, m."""
    centre_m: tuple[float, float] | None = None
    """A disc patch: its centre (x, y), m; with ``radius_m``."""
    radius_m: float | None = None
    """A disc patch: its radius, m."""
    x_range_m: tuple[float, float] | None = None
    """A rectangle patch: x from, to, m; with ``y_range_m``."""
    y_range_m: tuple[float, float] | None = None
    """A rectangle patch: y from, to, m."""

    def __post_init__(self) -> None:
        where = f"soil region {self.soil!r}"
        if not isinstance(self.soil, str) or not self.soil:
            raise InputError(f"soil region: soil = {self.soil!r}; must be a soil name or a .toml path")
        for key in ("slope_min_deg", "slope_max_deg"):
            if getattr(self, key) is not None:
                check_range(self, key, getattr(self, key), lo=0, hi=90, hi_open=True)
        check_range(self, "crater_radius_fraction", self.crater_radius_fraction, lo=0, lo_open=True, hi=1.5)
        check_range(self, "crater_min_diameter_m", self.crater_min_diameter_m, lo=0)
        if self.radius_m is not None:
            check_range(self, "radius_m", self.radius_m, lo=0, lo_open=True)
        if (self.centre_m is None) != (self.radius_m is None):
            raise InputError(f"{where}: a disc patch needs both centre_m and radius_m")
        if (self.x_range_m is None) != (self.y_range_m is None):
            raise InputError(f"{where}: a rectangle patch needs both x_range_m and y_range_m")
        conditions = (self.slope_min_deg, self.slope_max_deg, self.height_min_m, self.height_max_m,
                      self.centre_m, self.x_range_m)
        if not self.in_crater and all(c is None for c in conditions):
            raise InputError(f"{where}: gives no condition (slope, height, in_crater, a disc or a rectangle); "
                             "the whole map's soil is [soil] name")

    def mask(self, hm: Heightmap, craters: Sequence[tuple[float, float, float]] = ()) -> np.ndarray:
        """Boolean (rows, cols): the samples of ``hm`` this region covers; ``craters`` are (x m, y m,
        diameter m) of the recipe's population."""
        x = hm.x_coords_m()[None, :]
        y = hm.y_coords_m()[:, None]
        m = np.ones(hm.shape, dtype=bool)
        if self.slope_min_deg is not None or self.slope_max_deg is not None:
            gy, gx = np.gradient(hm.z, hm.cell_size_m)
            grad2 = gx * gx + gy * gy
            if self.slope_min_deg is not None:
                m &= grad2 >= math.tan(math.radians(self.slope_min_deg)) ** 2
            if self.slope_max_deg is not None:
                m &= grad2 <= math.tan(math.radians(self.slope_max_deg)) ** 2
        if self.height_min_m is not None:
            m &= hm.z >= self.height_min_m
        if self.height_max_m is not None:
            m &= hm.z <= self.height_max_m
        if self.in_crater:
            inside = np.zeros(hm.shape, dtype=bool)
            for cx, cy, d in craters:
                if d >= self.crater_min_diameter_m:
                    r = 0.5 * d * self.crater_radius_fraction
                    inside |= (x - cx) ** 2 + (y - cy) ** 2 <= r * r
            m &= inside
        if self.centre_m is not None:
            cx, cy = self.centre_m
            m &= (x - cx) ** 2 + (y - cy) ** 2 <= self.radius_m ** 2
        if self.x_range_m is not None:
            (x0, x1), (y0, y1) = sorted(self.x_range_m), sorted(self.y_range_m)
            m &= (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        return m


@dataclass(frozen=True, kw_only=True)
class SoilMapConfig:
    """A recipe's soil map (module docstring): a default soil, an optional raster and regions."""

    default: str
    """The soil where neither the raster nor a region says otherwise (``[soil] name``)."""
    regions: tuple[SoilRegion, ...] = ()
    """Regions, applied in order, each painting over the last."""
    raster: np.ndarray | None = field(default=None, compare=False)
    """Soil indices (rows, cols) read from ``[soil] raster`` when the recipe was built (io.soil_raster)."""
    raster_soils: tuple[str, ...] = ()
    """Index -> soil of the raster."""

    def soils(self) -> tuple[str, ...]:
        """Every soil the map may use, the default first, each once (the order of a SoilMap's indices)."""
        out = [self.default]
        for name in (*self.raster_soils, *(r.soil for r in self.regions)):
            if name not in out:
                out.append(name)
        return tuple(out)


@dataclass(frozen=True, eq=False)
class SoilMap:
    """The soil under each sample of a heightmap: ``index[r, c]`` into ``soils`` (index 0 the default)."""

    soils: tuple[str, ...]
    """Soil names (or .toml paths), by index."""
    index: np.ndarray
    """Soil index per sample, uint8, the heightmap's shape."""
    cell_size_m: float
    """The heightmap's sample spacing, m."""

    def __post_init__(self) -> None:
        if self.index.ndim != 2 or not self.soils or int(self.index.max(initial=0)) >= len(self.soils):
            raise InputError(f"soil map: indices must lie in 0..{len(self.soils) - 1}")

    def soil_index_at(self, x_m: float, y_m: float) -> int:
        """The soil index of the sample nearest (x, y), clamped to the map (plain floats: a per-step lookup)."""
        rows, cols = self.index.shape
        c = min(cols - 1, max(0, int(x_m / self.cell_size_m + 0.5)))
        r = min(rows - 1, max(0, int(y_m / self.cell_size_m + 0.5)))
        return int(self.index.item(r, c))

    def fractions(self) -> dict[str, float]:
        """{soil: fraction of the samples it covers}."""
        counts = np.bincount(self.index.ravel(), minlength=len(self.soils))
        return {s: float(n) / self.index.size for s, n in zip(self.soils, counts, strict=True)}


def soil_map_config(table: Mapping[str, Any], where: str, read_raster=None) -> SoilMapConfig | None:
    """The soil map of a recipe's ``[soil]`` table, or None when it names one soil only.

    ``read_raster(path) -> indices`` reads ``raster`` (the recipe passes offroadbench.io.soil_raster's)."""
    regions_tbl = table.get("regions", [])
    if not isinstance(regions_tbl, list) or not all(isinstance(r, dict) for r in regions_tbl):
        raise InputError(f"{where}: soil.regions must be an array of tables ([[soil.regions]])")
    regions = []
    for k, r in enumerate(regions_tbl):
        at = f"{where}: [[soil.regions]] #{k + 1}"
        unknown = sorted(set(r) - set(REGION_KEYS))
        if unknown:
            raise InputError(f"{at}: unknown key(s) {', '.join(unknown)}; known: {', '.join(REGION_KEYS)}")
        if "soil" not in r:
            raise InputError(f"{at}: needs soil = \"NAME\"")
        r = dict(r)
        for key in ("centre_m", "x_range_m", "y_range_m"):
            r[key] = _pair(r.get(key), key, at)
        try:
            regions.append(SoilRegion(**r))
        except TypeError as exc:
            raise InputError(f"{at}: {exc}") from None
    raster, raster_soils = None, tuple(table.get("raster_soils", ()))
    if "raster" in table:
        if not raster_soils or not all(isinstance(s, str) and s for s in raster_soils):
            raise InputError(f"{where}: soil.raster needs raster_soils = [\"SOIL\", ...] (index -> soil)")
        raster = (read_raster or _no_reader)(table["raster"])
        if int(raster.max(initial=0)) >= len(raster_soils) or int(raster.min(initial=0)) < 0:
            raise InputError(f"{where}: soil.raster {table['raster']} has index {int(raster.max())}; raster_soils "
                             f"names {len(raster_soils)} soil(s)")
    elif raster_soils:
        raise InputError(f"{where}: soil.raster_soils given without soil.raster")
    if not regions and raster is None:
        return None
    return SoilMapConfig(default=table["name"], regions=tuple(regions), raster=raster, raster_soils=raster_soils)


def _no_reader(path):
    raise InputError(f"soil raster {path}: no reader given")


def build_soil_map(cfg: SoilMapConfig, hm: Heightmap, craters: Sequence[tuple[float, float, float]] = ()) -> SoilMap:
    """The soil map of ``hm`` (pure): the default, then the raster, then each region in order."""
    soils = cfg.soils()
    index = np.zeros(hm.shape, dtype=np.uint8)
    if cfg.raster is not None:
        if cfg.raster.shape != hm.shape:
            raise InputError(f"soil raster: {cfg.raster.shape[0]} x {cfg.raster.shape[1]} pixels; the heightmap "
                             f"is {hm.rows} x {hm.cols} samples (one pixel per sample)")
        lookup = np.array([soils.index(s) for s in cfg.raster_soils], dtype=np.uint8)
        index = lookup[cfg.raster]
    for region in cfg.regions:
        index[region.mask(hm, craters)] = soils.index(region.soil)
    return SoilMap(soils=soils, index=index, cell_size_m=hm.cell_size_m)


def soil_map_for(recipe, hm: Heightmap, seed) -> SoilMap | None:
    """The soil map of a generated terrain (``recipe`` generated with ``seed`` into ``hm``), or None
    when the recipe names one soil; craters from the recipe's own population."""
    cfg = getattr(recipe, "soil_map", None)
    if cfg is None:
        return None
    craters: list[tuple[float, float, float]] = []
    if any(r.in_crater for r in cfg.regions):
        from offroadbench.terrain.craters.layer import recipe_craters

        for table in recipe_craters(recipe, seed).values():
            craters += list(zip(table.x_m.tolist(), table.y_m.tolist(), table.diameter_m.tolist(), strict=True))
    return build_soil_map(cfg, hm, craters)
