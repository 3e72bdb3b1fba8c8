"""The paper's terrain roughness study (Majhor & Bos 2023, Sec. 2.4 and 3.1, Fig. 5).

For each high-frequency fractal dimension D, generate N terrains and measure the area fraction of
the low / semi / high roughness classes inside the 5 m border, before the morphological closing.

Seeds (:mod:`offroadbench.seeding`): terrain j of every D is built from ``terrain_seed(seed, j)``,
the seed of terrain j of a paired study with ``root_seed = seed``, so the D values are compared on
the same random phases (common random numbers): the differences between D groups come from D, not
from which phases each group happened to draw. Results do not depend on run order. The table shows
each terrain's seed: ``offroadbench generate --seed <terrain_seed> --set <dim_key>=<D>`` rebuilds it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from offroadbench.analysis.roughness import RoughnessConfig, class_fractions, classify
from offroadbench.errors import InputError
from offroadbench.progress import ProgressFn, report
from offroadbench.seeding import terrain_seed
from offroadbench.terrain.recipe import Recipe, apply_overrides, generate_terrain

__all__ = ["RoughnessStudy", "run_roughness_study", "roughness_study", "summarise_roughness_study", "PAPER_FIG5_CHANGES_PP"]

#: Majhor & Bos 2023, Sec. 3.1: change of the median class areas, percentage points,
#: for D 2.3 -> 2.45 and 2.45 -> 2.6.
PAPER_FIG5_CHANGES_PP = {"low": (-13.8, -7.16), "semi": (11.7, 5.63), "high": (1.54, 3.33)}


def roughness_study(
    recipe: Recipe,
    dims: Sequence[float],
    terrains: int,
    seed: int,
    *,
    dim_key: str = "layers.base.D_high",
    roughness: RoughnessConfig = RoughnessConfig(),
    progress: ProgressFn | None = None,
) -> pd.DataFrame:
    """One row per (D, terrain): ``D``, ``terrain`` (index j), ``terrain_seed`` and the class area
    fractions in percent."""
    if terrains < 1:
        raise InputError(f"terrains must be >= 1, got {terrains}")
    if not dims:
        raise InputError("dims: give at least one fractal dimension")
    recipes = [apply_overrides(recipe, {dim_key: float(d)}) for d in dims]  # validates every D first
    seeds = [terrain_seed(seed, j) for j in range(terrains)]
    rows = []
    total = len(dims) * terrains
    for i, (d, rec) in enumerate(zip(dims, recipes, strict=True)):
        for j, tseed in enumerate(seeds):
            hm = generate_terrain(rec, tseed)
            frac = class_fractions(classify(hm, roughness), hm.cell_size_m, roughness.border_m)
            rows.append({"D": float(d), "terrain": j, "terrain_seed": tseed,
                         **{f"{k}_pct": 100.0 * v for k, v in frac.items()}})
            report(progress, i * terrains + j + 1, total)
    return pd.DataFrame(rows)


def summarise_roughness_study(table: pd.DataFrame) -> pd.DataFrame:
    """Median class areas (percent) per D, and their change from the previous D (percentage points)."""
    med = table.groupby("D")[["low_pct", "semi_pct", "high_pct"]].median()
    med.columns = ["median_low_pct", "median_semi_pct", "median_high_pct"]
    diff = med.diff()
    diff.columns = [c.replace("median_", "change_").replace("_pct", "_pp") for c in med.columns]
    out = pd.concat([med, diff], axis=1)
    out.insert(0, "terrains", table.groupby("D").size())
    return out.reset_index()


@dataclass(frozen=True, eq=False)
class RoughnessStudy:
    """The result of :func:`run_roughness_study`."""

    terrains: pd.DataFrame
    """One row per (D, terrain): ``D``, ``terrain``, ``terrain_seed`` (what ``generate --seed`` takes)
    and the class areas ``low_pct`` .. ``high_pct``."""
    summary: pd.DataFrame
    """Per D: terrains, median class areas (percent) and their change from the previous D (pp)."""
    paper_changes_pp: pd.DataFrame
    """Majhor & Bos 2023, Sec. 3.1: the changes of the median areas the paper reports (pp)."""


def run_roughness_study(
    recipe: Recipe,
    dims: Sequence[float],
    terrains: int,
    seed: int,
    *,
    dim_key: str = "layers.base.D_high",
    roughness: RoughnessConfig = RoughnessConfig(),
    progress: ProgressFn | None = None,
) -> RoughnessStudy:
    """The paper's Fig. 5 study: :func:`roughness_study`, its summary and the paper's figures."""
    table = roughness_study(recipe, dims, terrains, seed, dim_key=dim_key, roughness=roughness, progress=progress)
    paper = pd.DataFrame(
        {
            "class": list(PAPER_FIG5_CHANGES_PP),
            "paper_2.3_to_2.45_pp": [v[0] for v in PAPER_FIG5_CHANGES_PP.values()],
            "paper_2.45_to_2.6_pp": [v[1] for v in PAPER_FIG5_CHANGES_PP.values()],
        }
    )
    return RoughnessStudy(terrains=table, summary=summarise_roughness_study(table), paper_changes_pp=paper)
