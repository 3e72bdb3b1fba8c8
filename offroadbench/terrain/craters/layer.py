"""The ``craters`` terrain modifier: sample a population (or take a given crater list) and stamp it.

The modifier never reads a file: a recipe names a crater CSV with ``crater_file`` and
:mod:`offroadbench.terrain.recipe` reads it (through :mod:`offroadbench.io.craters_csv`) when the
recipe is loaded, handing the :class:`CraterTable` to the layer as ``craters``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.seeding import layer_rng, seed_sequence
from offroadbench.terrain.craters.population import PopulationConfig, degradation_from_age, sample_population
from offroadbench.terrain.craters.stamp import StampOptions, stamp_craters
from offroadbench.terrain.craters.table import CraterTable
from offroadbench.terrain.registry import register

__all__ = ["CraterConfig", "crater_table_for", "apply_craters", "recipe_craters"]


@dataclass(frozen=True, kw_only=True)
class CraterConfig:
    """A crater layer: a power-law population (Martin et al. 2014, Eq. 11-12, Yoshikawa & Nishiguchi 2001, Eq. 9, Li et al. 2022, Eq. 17-21) or a
    crater file (Parkes & Martin 1999, Sec. 3), stamped with a profile (Martin et al. 2014, Eq. 1-10, Yoshikawa & Nishiguchi 2001, Eq. 10-11, Li et al. 2022, Eq. 3-16).

    In a recipe: ``[layers.NAME.population]`` and ``[layers.NAME.stamp]`` tables (keys they leave
    out keep their defaults), and ``crater_file = "PATH"`` for craters from a file (read into
    ``craters`` when the recipe is loaded; a relative path is relative to the working directory).
    """

    population: PopulationConfig = field(default_factory=PopulationConfig)
    """The sizes, places, ages and profile of the sampled craters. With given ``craters`` only its
    Eq. (11) parameters are used, for craters that have no degradation."""
    stamp: StampOptions = field(default_factory=StampOptions)
    """How each crater is stamped (rim irregularity, roughness overlay, smallest crater)."""
    craters: CraterTable | None = None
    """Craters to stamp instead of sampling (e.g. from a crater file, Parkes & Martin 1999, Sec. 3);
    None samples the population."""
    degradation: float | None = None
    """If set, every crater gets this degradation (0 fresh .. 1) instead of one derived from age."""

    def __post_init__(self) -> None:
        if self.degradation is not None:
            check_range(self, "degradation", self.degradation, lo=0, hi=1)
        if self.craters is not None and not isinstance(self.craters, CraterTable):
            raise InputError(f"CraterConfig.craters must be a CraterTable, got {type(self.craters).__name__}")


def crater_table_for(cfg: CraterConfig, width_m: float, height_m: float, rng: np.random.Generator) -> CraterTable:
    """The craters the layer places, oldest first: the given ``craters`` or a population sampled
    on a width x height map.

    Given craters with an empty degradation get it from their age (Martin et al. 2014, Eq. 11).
    """
    pop = cfg.population
    if cfg.craters is not None:
        table = cfg.craters.oldest_first()
        missing = np.isnan(table.degradation)
        if missing.any():
            derived = degradation_from_age(pop, np.nan_to_num(table.age), table.diameter_m)
            table = table.with_degradation(np.where(missing, derived, table.degradation))
    else:
        table = sample_population(pop, width_m, height_m, rng)
    if cfg.degradation is not None:
        table = table.with_degradation(np.full(len(table), cfg.degradation))
    return table


@register(
    "craters",
    CraterConfig,
    kind="modifier",
    summary="Crater population stamped on the terrain (Martin et al. 2014; Yoshikawa; Li et al. 2022)",
)
def apply_craters(cfg: CraterConfig, hm: Heightmap, rng: np.random.Generator) -> Heightmap:
    """Sample (or take the given) craters and stamp them onto ``hm``, oldest first."""
    table = crater_table_for(cfg, hm.width_m, hm.height_m, rng)
    return stamp_craters(hm, table, rng, cfg.stamp)


def recipe_craters(recipe, seed) -> dict[str, CraterTable]:
    """{layer name: the craters it places} for every ``craters`` layer of a recipe and seed.

    Same random streams as :func:`offroadbench.terrain.recipe.generate_terrain`, so the tables are the
    craters in the generated terrain (e.g. to write a crater file or check the size-frequency
    distribution). Craters are sampled over the recipe's grid extent, as in generation (every
    registered generator and modifier keeps that extent in metres).
    """
    root = seed_sequence(seed)
    grid = recipe.grid
    return {
        layer.name: crater_table_for(layer.config, grid.width_m, grid.height_m, layer_rng(root, layer.name))
        for layer in recipe.layers
        if layer.generator == "craters"
    }
