"""Terrain recipes: named TOML files that layer registered generators into one Heightmap.

Format (``terrains/*.toml``)::

    [recipe]
    name = "paper-d2.45"
    description = "..."
    relief_m = 3.84          # optional: final rescale to min 0 .. relief_m
    crs = "IAU_2015:30110"   # optional: coordinate reference system of exports (geotiff); none = local metres

    [grid]
    rows = 1009
    cols = 1009
    cell_size_m = 0.05
    quantise = "png16"       # optional: "png16" (default, 16-bit levels) or "none" (float64, CPU-dependent bits)

    [layers.base]            # applied in file order; the table name is the layer's name
    generator = "multifractal"
    D_high = 2.45            # every other key goes to the generator's frozen config

Optional tables: ``[soil] name = "lunar-regolith"`` (the soil of the ``terramechanics`` tyre model,
``soils/*.toml``; with ``[[soil.regions]]`` or ``raster`` a soil map, offroadbench.terrain.soil_map) and ``[body] name = "moon"`` (``earth``, ``moon``, ``mars``) or
``[body] gravity_m_s2 = 1.62`` (offroadbench.bodies): trials on the terrain use them unless the
study's ``[sim]`` sets ``soil`` or ``gravity_m_s2``.

Layer keys besides the config: ``generator`` (required, a name in the terrain registry),
``combine`` (``replace`` | ``sum`` | ``product`` for generators, ``apply`` for modifiers; the
first layer must be a generator and defaults to ``replace``, later generators to ``sum``) and
``weight`` (factor on a ``sum`` layer, default 1). A nested table sets a nested config
(``[layers.craters.population]``, ``--set layers.craters.population.k=2``). Every generator
draws on the recipe's ``[grid]`` (a :class:`~offroadbench.terrain.grid.GridConfig`).

Files. Generators never read files: a layer that names one (``crater_file`` of a ``craters``
layer; ``path``, ``source_cell_size_m``, ``source_relief_m`` and ``nodata_level`` of a ``dem``
layer) has it read here, through :mod:`offroadbench.io`, when the recipe is built, and its config
holds the data (``CraterConfig.craters``, ``DEMConfig.dem``). Relative paths are relative to the
working directory; a DEM ``path = "matplotlib:NAME"`` names a sample file shipped with matplotlib.

Randomness: each layer's generator is seeded from (seed, layer name)
(:func:`offroadbench.seeding.layer_rng`), so adding, removing or reordering layers never changes
another layer's random numbers.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench import resources
from offroadbench.bodies import body_gravity
from offroadbench.config import check_int, check_range, config_id, from_dict, load_toml, set_dotted
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.levels16 import quantise
from offroadbench.seeding import layer_rng, seed_sequence
from offroadbench.io.craters_csv import read_craters
from offroadbench.io.dem import read_dem
from offroadbench.registry import unknown_name
from offroadbench.terrain.craters.table import CraterTable
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import get_spec

__all__ = [
    "Recipe",
    "Layer",
    "COMBINE_MODES",
    "list_presets",
    "load_recipe",
    "recipe_from_dict",
    "apply_overrides",
    "generate_terrain",
    "load_terrain",
]

COMBINE_MODES = ("replace", "sum", "product", "apply")
_LAYER_KEYS = ("generator", "combine", "weight")
_TOP_KEYS = ("recipe", "grid", "layers", "soil", "body")
_RECIPE_KEYS = ("name", "description", "relief_m", "crs")


@dataclass(frozen=True)
class Layer:
    """One validated layer: its name, registry entry name, how it combines, and its config."""

    name: str
    generator: str
    combine: str
    weight: float
    config: Any


@dataclass(frozen=True)
class Recipe:
    """A validated recipe. ``data`` is the plain TOML dict it was built from (for overrides/ids)."""

    name: str
    description: str
    relief_m: float | None
    grid: GridConfig
    layers: tuple[Layer, ...]
    data: Mapping[str, Any]
    source: str = ""
    soil: str | None = None
    """``[soil] name``: the soil of the terramechanics tyre model (offroadbench.sim.tyre_laws.terramechanics)."""
    body: str = "earth"
    """``[body]``: the body the terrain lies on (offroadbench.bodies)."""
    gravity_m_s2: float | None = None
    """Surface gravity of ``body``, m/s^2 (None: no ``[body]``; trials then use Earth's)."""
    soil_map: Any = None
    """The soil map of ``[soil]`` (offroadbench.terrain.soil_map.SoilMapConfig), None for one soil."""

    def terrain_id(self, seed: int | None) -> str:
        """Stable id of (recipe data, seed): same recipe and seed, same id."""
        return config_id(self.data, seed)


# --------------------------------------------------------------------------- presets
def list_presets() -> dict[str, str]:
    """{preset name: description} of every preset on the search path (:mod:`offroadbench.resources`).

    Finding none is an InputError: the installation lacks its data or ``OFFROADBENCH_PATH`` hides it.
    """
    found = resources.terrain_presets()
    if not found:
        where = ", ".join(str(r) for r in resources.roots("terrains"))
        raise InputError(f"no terrain presets found (searched {where}); "
                         f"add <dir>/terrains/*.toml to {resources.ENV_VAR} or reinstall offroadbench")
    return {name: str(load_toml(p).get("recipe", {}).get("description", "")) for name, p in found.items()}


def load_recipe(name_or_path: str | Path) -> Recipe:
    """Load a preset by name (``paper-d2.45``) or a recipe TOML by path."""
    text = str(name_or_path)
    p = Path(text)
    if text.endswith(".toml") or p.exists():
        _check_recipe_kind(p)
        return recipe_from_dict(load_toml(p), source=str(p))
    presets = resources.terrain_presets()
    if text not in presets:
        raise unknown_name("terrain preset", text, presets, extra="(or give a path to a .toml)")
    return recipe_from_dict(load_toml(presets[text]), source=str(presets[text]))


def _check_recipe_kind(p: Path) -> None:
    """Name what a file handed in as a recipe is when it is plainly not TOML (an image, a sidecar)."""
    from offroadbench.io.inputs import file_kind

    kind = file_kind(p) if p.is_file() else None
    if kind is None:
        return
    hint = ("if it is a PNG heightmap's sidecar, give the .png beside it" if kind == "a JSON file" else
            "a PNG heightmap is read from a .png name (16-bit grayscale, with its .json sidecar)" if kind == "a PNG image" else
            "terrain commands take a 16-bit PNG heightmap (with its .json sidecar), a preset name or a recipe .toml")
    raise InputError(f"{p}: {kind}, not a terrain recipe (TOML); {hint}")


# --------------------------------------------------------------------------- files
def _crater_file(params: dict[str, Any], where: str, key: str) -> dict[str, Any]:
    """``crater_file = PATH`` -> ``craters``: the CraterTable read from the CSV."""
    if "craters" in params:
        raise InputError(f"{where}: {key}.craters cannot be written in a recipe; name a crater CSV with crater_file")
    path = params.pop("crater_file", None)
    if path is None:
        return params
    if not isinstance(path, str):
        raise InputError(f"{where}: {key}.crater_file must be a path string, got {path!r}")
    try:
        params["craters"] = CraterTable(**read_craters(path))
    except InputError as exc:
        raise InputError(f"{where}: {key}.crater_file = {path!r}: {exc}") from None
    return params


def _dem_file(params: dict[str, Any], where: str, key: str) -> dict[str, Any]:
    """``path`` (+ read options) -> ``dem``: the RawDEM read from the file (the sample without a path)."""
    if "dem" in params:
        raise InputError(f"{where}: {key}.dem cannot be written in a recipe; name the DEM file with path")
    path = params.pop("path", None)
    opts = {name: params.pop(name, None) for name in ("source_cell_size_m", "source_relief_m", "nodata_level")}
    if path is not None and not isinstance(path, str):
        raise InputError(f"{where}: {key}.path must be a path string, got {path!r}")
    if opts["source_cell_size_m"] is not None:
        check_range(None, f"{key}.source_cell_size_m", opts["source_cell_size_m"], lo=0, lo_open=True)
    if opts["source_relief_m"] is not None:
        check_range(None, f"{key}.source_relief_m", opts["source_relief_m"], lo=0)
    if opts["nodata_level"] is not None:
        check_int(None, f"{key}.nodata_level", opts["nodata_level"], lo=0, hi=65535)
    if path is None:
        source = resources.sample_dem()
    elif path.startswith("matplotlib:"):  # a real DEM shipped with matplotlib (terrains/jacksboro-*.toml)
        source = resources.matplotlib_sample(path.partition(":")[2])
    else:
        source = Path(path)
    params["dem"] = read_dem(
        source,
        cell_size_m=opts["source_cell_size_m"],
        relief_m=opts["source_relief_m"],
        nodata_level=opts["nodata_level"],
    )
    return params


#: generator name -> reader of the files its layer names (params, where, key) -> params
_FILE_READERS = {"craters": _crater_file, "dem": _dem_file}


# --------------------------------------------------------------------------- validation
def _check_keys(table: Mapping[str, Any], allowed, where: str) -> None:
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: expected a table, got {type(table).__name__} {table!r:.40}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: {', '.join(allowed)}")


def _build_layer(lname: str, table: Mapping[str, Any], first: bool, where: str) -> Layer:
    if not isinstance(table, dict):
        raise InputError(f"{where}: layers.{lname} must be a table")
    if "generator" not in table:
        raise InputError(f"{where}: layers.{lname} has no 'generator' key")
    spec = get_spec(str(table["generator"]))
    default_combine = "apply" if spec.kind == "modifier" else ("replace" if first else "sum")
    combine = str(table.get("combine", default_combine))
    if combine not in COMBINE_MODES:
        raise InputError(f"{where}: layers.{lname}.combine = {combine!r}; allowed: {', '.join(COMBINE_MODES)}")
    if (spec.kind == "modifier") != (combine == "apply"):
        raise InputError(
            f"{where}: layers.{lname}: {spec.kind} {spec.name!r} cannot use combine = {combine!r} "
            f"({'modifiers use apply' if spec.kind == 'modifier' else 'apply is for modifiers'})"
        )
    if first and spec.kind == "modifier":
        raise InputError(f"{where}: the first layer ({lname}) must be a generator, got modifier {spec.name!r}")
    weight = table.get("weight", 1.0)
    if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not np.isfinite(weight):
        raise InputError(f"{where}: layers.{lname}.weight must be a finite number, got {weight!r}")
    params = {k: v for k, v in table.items() if k not in _LAYER_KEYS}
    if spec.name in _FILE_READERS:
        params = _FILE_READERS[spec.name](params, where, f"layers.{lname}")
    cfg = from_dict(spec.config_cls, params, where=where, key=f"layers.{lname}")
    return Layer(name=lname, generator=spec.name, combine=combine, weight=float(weight), config=cfg)


def recipe_from_dict(data: Mapping[str, Any], source: str = "") -> Recipe:
    """Validate a recipe dict (as read from TOML). Errors name the file and the key."""
    where = source or "recipe"
    _check_keys(data, _TOP_KEYS, where)
    meta = data.get("recipe", {})
    _check_keys(meta, _RECIPE_KEYS, f"{where}: [recipe]")
    grid_keys = [f.name for f in dataclasses.fields(GridConfig) if f.name != "quantise"]
    table = data.get("grid")
    if not isinstance(table, dict):
        raise InputError(f"{where}: missing [grid] table with {', '.join(grid_keys)}")
    missing = [k for k in grid_keys if k not in table]
    if missing:
        raise InputError(f"{where}: [grid] is missing {', '.join(missing)}")
    grid = from_dict(GridConfig, table, where=where, key="grid")
    relief = meta.get("relief_m")
    if relief is not None and (isinstance(relief, bool) or not isinstance(relief, (int, float)) or not relief > 0):
        raise InputError(f"{where}: recipe.relief_m = {relief!r}; must be a number > 0 (metres)")
    if not isinstance(meta.get("crs", ""), str):
        raise InputError(f"{where}: recipe.crs = {meta['crs']!r}; must be a string such as \"IAU_2015:30110\"")
    layers_tbl = data.get("layers")
    if not isinstance(layers_tbl, dict) or not layers_tbl:
        raise InputError(f"{where}: needs at least one [layers.NAME] table")
    layers = tuple(
        _build_layer(lname, tbl, i == 0, where) for i, (lname, tbl) in enumerate(layers_tbl.items())
    )
    name = str(meta.get("name", Path(source).stem if source else "recipe"))
    soil = _soil_name(data.get("soil"), where)
    soil_map = _soil_map(data.get("soil"), where)
    body, gravity = body_gravity(data["body"], f"{where}: [body]") if "body" in data else ("earth", None)
    return Recipe(
        name=name,
        description=str(meta.get("description", "")),
        relief_m=None if relief is None else float(relief),
        grid=grid,
        layers=layers,
        data=copy.deepcopy(dict(data)),
        source=source,
        soil=soil,
        body=body,
        gravity_m_s2=gravity,
        soil_map=soil_map,
    )


def _soil_name(table: Any, where: str) -> str | None:
    """The ``[soil] name`` of a recipe (a soil name or .toml path, checked when a trial loads it)."""
    if table is None:
        return None
    from offroadbench.terrain.soil_map import SOIL_KEYS

    _check_keys(table, SOIL_KEYS, f"{where}: [soil]")
    name = table.get("name")
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}: soil.name = {name!r}; must be a soil name (soils/*.toml) or a .toml path")
    return name


def _soil_map(table: Any, where: str):
    """The soil map of a recipe's ``[soil]`` (its raster read here, through offroadbench.io), or None."""
    if table is None:
        return None
    from offroadbench.io.soil_raster import read_soil_raster
    from offroadbench.terrain.soil_map import soil_map_config

    return soil_map_config(table, where, read_raster=read_soil_raster)


def apply_overrides(recipe: Recipe, overrides: Mapping[str, Any]) -> Recipe:
    """A new recipe with dotted TOML keys replaced, e.g. ``{"layers.base.D_high": 2.6}``.

    A key into a layer that the recipe does not have is refused with the layer names listed;
    any other unknown key is refused by the loader, naming its dotted path.
    """
    data = dict(recipe.data)
    layers = data.get("layers", {})
    for key, value in overrides.items():
        parts = key.split(".")
        if parts[0] == "layers" and len(parts) > 2 and parts[1] not in layers:
            raise InputError(f"--set {key}: the recipe has no layer {parts[1]!r}; layers: {', '.join(layers)}")
        data = set_dotted(data, key, value)
    return recipe_from_dict(data, source=recipe.source)


# --------------------------------------------------------------------------- generation
def generate_terrain(recipe: Recipe, seed: int | np.random.SeedSequence) -> Heightmap:
    """Run the recipe's layers in order and return the Heightmap (pure: no I/O).

    The finished map is rescaled to ``[recipe] relief_m`` if given, then quantised as
    ``[grid] quantise`` says (default: the 16-bit levels of the PNG export, portable across CPUs).
    """
    root = seed_sequence(seed)
    shape = recipe.grid.shape
    hm: Heightmap | None = None
    for layer in recipe.layers:
        spec = get_spec(layer.generator)
        rng = layer_rng(root, layer.name)
        if spec.kind == "modifier":
            hm = spec.fn(layer.config, hm, rng)
            continue
        new = spec.fn(layer.config, recipe.grid, rng)
        if new.shape != shape and layer.combine != "replace":
            raise InputError(
                f"{recipe.source or recipe.name}: layer {layer.name} made a {new.shape} grid, the recipe's grid is {shape}"
            )
        if hm is None or layer.combine == "replace":
            hm = new
        elif layer.combine == "sum":
            hm = hm.with_z(hm.z + layer.weight * new.z)
        else:  # product
            hm = hm.with_z(hm.z * new.z)
    assert hm is not None
    if recipe.relief_m is not None:
        hm = hm.rescaled(recipe.relief_m)
    if recipe.grid.quantise == "png16":
        hm = hm.with_z(quantise(hm.z))
    return hm


def load_terrain(source, seed: int | None = None, overrides: Mapping[str, Any] | None = None):
    """(Heightmap, Recipe or None) from what a user names a terrain by: a Heightmap (as it is), a
    16-bit PNG path (read with its sidecar; ``seed`` and ``overrides`` do not apply), a Recipe, or a
    preset name / recipe TOML path (generated with ``seed`` after the dotted ``overrides``).

    The one loader of the CLI commands and the Gymnasium env.
    """
    if isinstance(source, Heightmap):
        if overrides:
            raise InputError("terrain overrides apply to a preset or recipe, not to a Heightmap")
        return source, None
    if isinstance(source, (str, Path)) and str(source).lower().endswith(".png"):
        from offroadbench.io.png16 import read_png16

        if overrides:
            raise InputError("--set applies to presets and recipes, not to a PNG heightmap")
        return read_png16(source), None
    recipe = source if isinstance(source, Recipe) else load_recipe(source)
    if overrides:
        recipe = apply_overrides(recipe, overrides)
    if seed is None:
        raise InputError(f"{recipe.name}: a generated terrain needs a seed")
    return generate_terrain(recipe, seed), recipe
