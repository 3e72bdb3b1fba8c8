"""Terrain figures. Functions return matplotlib Figures; the caller saves them (the CLI, atomically).

Maps are drawn with ``origin="lower"`` and ``extent=hm.extent_m``, so x is east and y north in metres.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.colors import LightSource

from offroadbench.analysis.roughness import CLASS_NAMES
from offroadbench.heightmap import Heightmap
from offroadbench.plots.style import CLASS_COLOURS, class_legend_handles, draw_border, draw_classes, height_limits, new_figure

__all__ = ["hillshade", "plot_terrain_classes", "plot_roughness_study"]


def hillshade(hm: Heightmap, azimuth_deg: float = 315.0, altitude_deg: float = 45.0) -> np.ndarray:
    """Shaded relief in [0, 1] with the true vertical scale (no exaggeration)."""
    ls = LightSource(azdeg=azimuth_deg, altdeg=altitude_deg)
    # LightSource assumes row 0 at the top; flip, shade, flip back to keep origin="lower"
    shade = ls.hillshade(hm.z[::-1], dx=hm.cell_size_m, dy=hm.cell_size_m)
    return shade[::-1]


def plot_terrain_classes(
    hm: Heightmap,
    classes: np.ndarray,
    *,
    fractions: dict[str, float] | None = None,
    border_m: float | None = None,
    title: str = "",
):
    """Hillshade beside the colour-coded roughness class map (the paper's Fig. 4a)."""
    fig, axes = new_figure(1, 2, figsize=(12, 5.6))
    ax = axes[0]
    ax.imshow(hillshade(hm), cmap="gray", origin="lower", extent=hm.extent_m, vmin=0, vmax=1)
    vmin, vmax, extend = height_limits(hm.z)  # percentile limits: a corner spire must not flatten the colours
    im = ax.imshow(hm.z, cmap="terrain", origin="lower", extent=hm.extent_m, alpha=0.35, vmin=vmin, vmax=vmax)
    fig.colorbar(im, ax=ax, shrink=0.8, label="height (m)", extend=extend)
    ax.set_title("hillshade and height")
    ax = axes[1]
    draw_classes(ax, classes, hm.extent_m)
    if border_m:
        draw_border(ax, hm.extent_m, border_m)
    ax.legend(handles=class_legend_handles(fractions), loc="upper right", fontsize=8, framealpha=0.9)
    ax.set_title("Moore-gradient roughness classes (Eq. 3-4)")
    for ax in axes:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    if title:
        fig.suptitle(title)
    return fig


def plot_roughness_study(summary: pd.DataFrame, paper_changes: dict[str, tuple[float, ...]] | None = None):
    """Bar charts of the median low / semi / high area per D (the paper's Fig. 5)."""
    fig, axes = new_figure(1, 3, figsize=(12, 4))
    labels = [f"{d:g}" for d in summary["D"]]
    for ax, name, colour in zip(axes, CLASS_NAMES, CLASS_COLOURS, strict=True):
        vals = summary[f"median_{name}_pct"].to_numpy()
        bars = ax.bar(labels, vals, color=colour, edgecolor="k")
        ax.bar_label(bars, fmt="%.1f", fontsize=8)
        ax.set_title(f"median {name}-roughness area")
        xlabel = "D of the high-frequency DEM"
        if paper_changes and len(vals) == len(paper_changes[name]) + 1:
            ours = ", ".join(f"{c:+.2f}" for c in np.diff(vals))
            paper = ", ".join(f"{c:+.2f}" for c in paper_changes[name])
            xlabel += f"\nchange (pp) ours: {ours}\npaper: {paper}"
        ax.set_xlabel(xlabel)
        ax.set_ylabel("area (%)")
        ax.set_ylim(0, max(vals.max(), 1e-9) * 1.12)
    fig.suptitle(f"Terrain roughness vs D ({int(summary['terrains'].iloc[0])} terrains per D)")
    return fig
