"""Terrain figures. Functions return matplotlib Figures; the caller saves them (the CLI, atomically).

Maps are drawn with ``origin="lower"`` and ``extent=hm.extent_m``, so x is east and y north in metres.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.colors import LightSource, ListedColormap  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from offroadbench.analysis.roughness import CLASS_NAMES  # noqa: E402
from offroadbench.heightmap import Heightmap  # noqa: E402

__all__ = ["CLASS_COLOURS", "class_cmap", "hillshade", "plot_terrain_classes", "plot_roughness_study"]

#: The paper's Fig. 4 colours: low blue, semi orange, high yellow.
CLASS_COLOURS = ("#1f5fbf", "#f08c1a", "#f5e52a")


def class_cmap() -> ListedColormap:
    return ListedColormap(CLASS_COLOURS, name="roughness")


def hillshade(hm: Heightmap, azimuth_deg: float = 315.0, altitude_deg: float = 45.0) -> np.ndarray:
    """Shaded relief in [0, 1] with the true vertical scale (no exaggeration)."""
    ls = LightSource(azdeg=azimuth_deg, altdeg=altitude_deg)
    # LightSource assumes row 0 at the top; flip, shade, flip back to keep origin="lower"
    shade = ls.hillshade(hm.z[::-1], dx=hm.cell_size_m, dy=hm.cell_size_m)
    return shade[::-1]


def _class_legend(ax, fractions: dict[str, float] | None) -> None:
    handles = []
    for name, colour in zip(CLASS_NAMES, CLASS_COLOURS):
        label = name if fractions is None else f"{name} {100 * fractions[name]:.1f} %"
        handles.append(Patch(facecolor=colour, edgecolor="k", label=label))
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)


def plot_terrain_classes(
    hm: Heightmap,
    classes: np.ndarray,
    *,
    fractions: dict[str, float] | None = None,
    border_m: float | None = None,
    title: str = "",
):
    """Hillshade beside the colour-coded roughness class map (the paper's Fig. 4a)."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6), constrained_layout=True)
    ax = axes[0]
    ax.imshow(hillshade(hm), cmap="gray", origin="lower", extent=hm.extent_m, vmin=0, vmax=1)
    im = ax.imshow(hm.z, cmap="terrain", origin="lower", extent=hm.extent_m, alpha=0.35)
    fig.colorbar(im, ax=ax, shrink=0.8, label="height (m)")
    ax.set_title("hillshade and height")
    ax = axes[1]
    ax.imshow(classes, cmap=class_cmap(), vmin=-0.5, vmax=2.5, origin="lower", extent=hm.extent_m, interpolation="nearest")
    if border_m:
        x0, x1, y0, y1 = hm.extent_m
        ax.add_patch(plt.Rectangle((x0 + border_m, y0 + border_m), x1 - x0 - 2 * border_m, y1 - y0 - 2 * border_m,
                                   fill=False, edgecolor="k", linestyle="--", linewidth=1))
    _class_legend(ax, fractions)
    ax.set_title("Moore-gradient roughness classes (Eq. 3-4)")
    for ax in axes:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    if title:
        fig.suptitle(title)
    return fig


def plot_roughness_study(summary: pd.DataFrame, paper_changes: dict[str, tuple[float, ...]] | None = None):
    """Bar charts of the median low / semi / high area per D (the paper's Fig. 5)."""
    fig, axes = plt.subplots(1, 3, figsize=(12, 4), constrained_layout=True)
    labels = [f"{d:g}" for d in summary["D"]]
    for ax, name, colour in zip(axes, CLASS_NAMES, CLASS_COLOURS):
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
