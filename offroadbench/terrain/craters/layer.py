"""The ``craters`` terrain modifier: sample a population (or read a crater file) and stamp it."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.craters.population import SAMPLINGS, PopulationConfig, degradation_from_age, sample_population
from offroadbench.terrain.craters.profiles import get_profile
from offroadbench.terrain.craters.stamp import StampOptions, stamp_craters
from offroadbench.terrain.craters.table import CraterTable
from offroadbench.terrain.registry import register

__all__ = ["CraterConfig", "crater_table_for", "apply_craters", "recipe_craters"]


@dataclass(frozen=True, kw_only=True)
class CraterConfig:
    """A crater layer: a power-law population (Martin et al. 2014, Eq. 11-12, Yoshikawa & Nishiguchi 2001, Eq. 9, Li et al. 2022, Eq. 17-21) or a
    crater file (Parkes & Martin 1999, Sec. 3), stamped with a profile (Martin et al. 2014, Eq. 1-10, Yoshikawa & Nishiguchi 2001, Eq. 10-11, Li et al. 2022, Eq. 3-16).
    """

    profile: str = "martin2014"
    """Crater profile: martin2014, yoshikawa, li_gaussian, li_flat_floor, li_fresh, li_complex."""
    k: float = 1.8
    """Cumulative power-law slope, N_cum(D) = c D^-k (Martin et al. 2014, Eq. 12); mare 1.8, saturated 2.0."""
    c: float = 0.03
    """Craters per m^2 with diameter >= 1 m."""
    d_min_m: float = 0.3
    """Smallest crater diameter, metres."""
    d_max_m: float = 10.0
    """Largest crater diameter, metres."""
    sampling: str = "inversion"
    """``inversion`` (Li et al. 2022, Eq. 17-21, random) or ``kth_largest`` (Yoshikawa & Nishiguchi 2001, Eq. 9, deterministic sizes)."""
    size_bins: int = 3
    """Log-spaced size bins for inversion sampling."""
    max_age: float = 1.0
    """Ages uniform in [0, max_age] (baseline full-degradation times); larger = more degraded."""
    baseline_diameter_m: float = 1.0
    """D_b of Martin et al. 2014, Eq. (11)."""
    erosion_exponent: float = 1.1
    """P of Martin et al. 2014, Eq. (11)."""
    density_ratio: float = 1.0
    """sigma_b / sigma_x of Martin et al. 2014, Eq. (11)."""
    degradation: float | None = None
    """If set, every crater gets this degradation (0 fresh .. 1) instead of one derived from age."""
    crater_file: str | None = None
    """A crater CSV (x_m, y_m, diameter_m, age, degradation, profile) used instead of sampling;
    a relative path is relative to the working directory. The population fields then only serve
    Eq. (11) for craters without a degradation."""
    rim_irregularity: float = 0.0
    """Std of the fractal rim radius perturbation, fraction of the radius (0 = circular)."""
    rim_fractal_dimension: float = 1.5
    """Fractal dimension of the rim perturbation, (1, 2)."""
    roughness: float = 0.0
    """Rms of the fractal overlay by radial zone, fraction of the fresh depth H0 (0 = none)."""
    roughness_D_interior: float = 2.2
    """Fractal dimension of the overlay inside the rim."""
    roughness_D_ejecta: float = 2.4
    """Fractal dimension of the overlay on the ejecta."""
    min_diameter_cells: float = 2.0
    """Craters below this many cells across are skipped."""

    def __post_init__(self) -> None:
        get_profile(self.profile)
        check_choice(self, "sampling", self.sampling, SAMPLINGS)
        check_int(self, "size_bins", self.size_bins, lo=1)
        if self.degradation is not None:
            check_range(self, "degradation", self.degradation, lo=0, hi=1)
        if self.crater_file is not None and not isinstance(self.crater_file, str):
            raise InputError(f"CraterConfig.crater_file must be a path string, got {self.crater_file!r}")
        self.population()
        self.stamp_options()

    def population(self) -> PopulationConfig:
        """The population part of this config."""
        names = {f.name for f in dataclasses.fields(PopulationConfig)}
        return PopulationConfig(**{n: getattr(self, n) for n in names})

    def stamp_options(self) -> StampOptions:
        """The stamping part of this config."""
        names = {f.name for f in dataclasses.fields(StampOptions)}
        return StampOptions(**{n: getattr(self, n) for n in names})


def crater_table_for(cfg: CraterConfig, width_m: float, height_m: float, rng: np.random.Generator) -> CraterTable:
    """The craters the layer places, oldest first: read from ``crater_file`` or sampled on a
    width x height map.

    Craters from a file with an empty degradation get it from their age (Martin et al. 2014, Eq. 11).
    """
    pop = cfg.population()
    if cfg.crater_file is not None:
        from offroadbench.io.craters_csv import read_craters

        table = read_craters(cfg.crater_file).oldest_first()
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
    """Sample (or read) the craters and stamp them onto ``hm``, oldest first."""
    table = crater_table_for(cfg, hm.width_m, hm.height_m, rng)
    return stamp_craters(hm, table, rng, cfg.stamp_options())


def recipe_craters(recipe, seed) -> dict[str, CraterTable]:
    """{layer name: the craters it places} for every ``craters`` layer of a recipe and seed.

    Same random streams as :func:`offroadbench.terrain.recipe.generate_terrain`, so the tables are the
    craters in the generated terrain (e.g. to write a crater file or check the size-frequency
    distribution). Craters are sampled over the recipe's grid extent, as in generation (every
    registered generator and modifier keeps that extent in metres).
    """
    from offroadbench.terrain.recipe import layer_rng, seed_sequence

    root = seed_sequence(seed)
    grid = recipe.grid
    width = (grid["cols"] - 1) * grid["cell_size_m"]
    height = (grid["rows"] - 1) * grid["cell_size_m"]
    return {
        layer.name: crater_table_for(layer.config, width, height, layer_rng(root, layer.name))
        for layer in recipe.layers
        if layer.generator == "craters"
    }
