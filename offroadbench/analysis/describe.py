"""Everything ``offroadbench analyze`` reports about one terrain, as one result object.

:func:`describe_terrain` runs the roughness pipeline (Majhor & Bos 2023, Eq. 3-4 and Sec. 2.4:
Moore gradient, classes, morphological closing), the surface statistics (Horn slopes, radially
averaged power spectrum) and, when the caller hands in the diameters of the craters a recipe
placed, the maximum-likelihood slope of their cumulative size-frequency distribution. It does no
I/O and prints nothing; the CLI formats the :class:`TerrainReport`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd

from offroadbench.analysis.roughness import (
    CLASS_NAMES,
    ClassMaps,
    RoughnessConfig,
    border_mask,
    class_fractions,
    classify_terrain,
    gradient_map,
)
from offroadbench.heightmap import Heightmap

__all__ = ["TerrainReport", "describe_terrain"]


@dataclass(frozen=True, eq=False)
class TerrainReport:
    """What :func:`describe_terrain` found on one terrain."""

    heightmap: Heightmap
    """The terrain described."""
    roughness: RoughnessConfig
    """The thresholds, border and closing radius used."""
    maps: ClassMaps
    """Class maps before and after the closing."""
    gradient_p50: float
    """Median Moore gradient (rise/run) over the whole map."""
    gradient_p95: float
    """95th percentile of the Moore gradient (rise/run)."""
    gradient_max: float
    """Largest Moore gradient (rise/run)."""
    classes: pd.DataFrame
    """One row per class: ``class``, ``max_slope`` (the threshold as text), ``area_pct`` and
    ``area_m2`` inside the border, ``whole_map_pct`` and ``after_closing_pct`` (inside the border)."""
    surface: dict
    """:func:`offroadbench.analysis.surface.surface_summary` of the map (slope percentiles in
    degrees, fractions steeper than 10/20/30 deg, PSD slope beta, fractal dimension)."""
    crater_diameters_m: np.ndarray | None
    """Diameters of the placed craters, metres, or None (no crater layer, or a PNG)."""
    crater_sfd_slope: float | None
    """Fitted cumulative SFD slope k (N_cum ~ D^-k) of those craters; None with fewer than 2."""


def describe_terrain(
    hm: Heightmap,
    rcfg: RoughnessConfig = RoughnessConfig(),
    *,
    crater_diameters_m: Sequence[float] | np.ndarray | None = None,
) -> TerrainReport:
    """Describe ``hm``: roughness classes before and after the closing, areas, surface, craters."""
    from offroadbench.analysis.surface import fit_sfd_slope, surface_summary

    grad = gradient_map(hm)
    maps = classify_terrain(hm, rcfg)
    inside, closed = maps.fractions, maps.closed_fractions
    whole = class_fractions(maps.classes, hm.cell_size_m, 0.0)
    inside_area_m2 = int(border_mask(hm.shape, rcfg.border_m, hm.cell_size_m).sum()) * hm.cell_size_m**2
    table = pd.DataFrame(
        {
            "class": list(CLASS_NAMES),
            "max_slope": [f"<= {rcfg.low_max_slope:.3f}", f"<= {rcfg.semi_max_slope:.3f}", f"> {rcfg.semi_max_slope:.3f}"],
            "area_pct": [100 * inside[c] for c in CLASS_NAMES],
            "area_m2": [inside[c] * inside_area_m2 for c in CLASS_NAMES],
            "whole_map_pct": [100 * whole[c] for c in CLASS_NAMES],
            "after_closing_pct": [100 * closed[c] for c in CLASS_NAMES],
        }
    )
    diameters = None if crater_diameters_m is None else np.asarray(crater_diameters_m, dtype=float)
    slope = fit_sfd_slope(diameters) if diameters is not None and diameters.size >= 2 else None
    return TerrainReport(
        heightmap=hm,
        roughness=rcfg,
        maps=maps,
        gradient_p50=float(np.median(grad)),
        gradient_p95=float(np.percentile(grad, 95)),
        gradient_max=float(grad.max()),
        classes=table,
        surface=surface_summary(hm),
        crater_diameters_m=diameters,
        crater_sfd_slope=slope,
    )
