"""The terrain recipe sections of the settings reference (offroadbench.reference): the layers,
the grid and the keys that name files."""

from __future__ import annotations

import dataclasses
import typing

from offroadbench.reference_fields import REQUIRED, FieldDoc, SectionDoc, first_line, qualname, field_docs


# ---------------------------------------------------------------------------- terrain recipes
def nested_sections(key: str, cls: type, summary: str, generator: str) -> list[SectionDoc]:
    """``key``'s table and, recursively, the tables of its fields that are configs themselves."""
    from offroadbench.config import dataclass_type

    fields = field_docs(cls)
    out = [SectionDoc(key, qualname(cls), summary, fields, generator=generator)]
    hints = typing.get_type_hints(cls)
    for f in fields:
        sub = dataclass_type(hints.get(f.name))
        if sub is not None and sub.__name__.endswith(("Config", "Options")):  # not data (a crater table, a DEM)
            out += nested_sections(f"{key}.{f.name}", sub, first_line(sub), generator)
    return out


#: layer keys that name a file, read when the recipe is loaded (offroadbench.terrain.recipe's file
#: readers), in place of the data field they fill
FILE_KEYS: dict[str, tuple[str, tuple[FieldDoc, ...]]] = {
    "craters": ("craters", (
        FieldDoc("crater_file", "str", None, "", "a path",
                 "A crater CSV (offroadbench.io.craters_csv): these craters are stamped instead of sampling the "
                 "population (read when the recipe is loaded)."),)),
    "dem": ("dem", (
        FieldDoc("path", "str", None, "", "a path", "The DEM file (16-bit PNG + sidecar, .npy, a geographic .npz "
                 "with non-square cells, or GeoTIFF), read when the recipe is loaded; `matplotlib:NAME`: a sample "
                 "file shipped with matplotlib (`matplotlib:jacksboro_fault_dem.npz`, a real DEM); none: the "
                 "shipped sample DEM."),
        FieldDoc("source_cell_size_m", "float", None, "m", "(0, inf)", "Cell size of a DEM file without metadata."),
        FieldDoc("source_relief_m", "float", None, "m", "[0, inf)", "Relief of a 16-bit PNG without metadata."),
        FieldDoc("nodata_level", "int", None, "", "integer 0 .. 65535", "16-bit level that marks missing heights "
                 "(filled, Martin et al. 2014, Sec. IV.B)."),
    )),
}


def recipe_sections() -> list[SectionDoc]:
    """The tables of a terrain recipe (what ``[recipe_overrides]``, ``recipe.<key>`` grid axes and
    ``generate --set`` reach): ``[grid]`` and, per built-in generator or modifier, its layer table."""
    from offroadbench.terrain.grid import GridConfig
    from offroadbench.terrain.recipe import COMBINE_MODES
    from offroadbench.terrain.registry import TERRAIN_REGISTRY

    out = [SectionDoc("grid", qualname(GridConfig), first_line(GridConfig), field_docs(GridConfig))]
    names = sorted(n for n, spec in TERRAIN_REGISTRY.items() if spec.config_cls.__module__.startswith("offroadbench."))
    layer = (
        FieldDoc("generator", "str", REQUIRED, "", "one of " + ", ".join(f'"{n}"' for n in names),
                 "The registered generator or modifier of this layer (`offroadbench terrains` lists them)."),
        FieldDoc("combine", "str", None, "", "one of " + ", ".join(f'"{c}"' for c in COMBINE_MODES),
                 "How the layer joins the terrain so far: the first generator replaces, later generators sum "
                 "(or multiply); modifiers apply."),
        FieldDoc("weight", "float", 1.0, "", "", "Factor on the layer's heights where it is summed."),
    )
    out.append(SectionDoc("layers.NAME", "offroadbench.terrain.recipe", "Every layer table (applied in file order).",
                          layer))
    for name in names:
        spec = TERRAIN_REGISTRY.get(name)
        tables = nested_sections("layers.NAME", spec.config_cls, f"{spec.kind} `{name}`: {spec.summary}", name)
        if name in FILE_KEYS:  # the file's keys stand where the data field they fill would
            data, keys = FILE_KEYS[name]
            top = tables[0]
            tables[0] = dataclasses.replace(top, fields=(*keys, *(f for f in top.fields if f.name != data)))
        out += tables
    return out
