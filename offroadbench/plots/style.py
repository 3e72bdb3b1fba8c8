"""One look for every figure: the class palette of the paper's Fig. 4 and shared drawing helpers.

Figures are built on :class:`matplotlib.figure.Figure` objects (no pyplot state, no backend
choice); the CLI picks the backend and saves them.
"""

from __future__ import annotations

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from offroadbench.analysis.roughness import CLASS_NAMES

__all__ = ["CLASS_COLOURS", "HEIGHT_PERCENTILE", "class_cmap", "new_figure", "draw_border", "class_legend_handles", "draw_classes", "height_limits"]

#: height colour maps span the HEIGHT_PERCENTILE .. 100 - HEIGHT_PERCENTILE percentiles of the map
HEIGHT_PERCENTILE = 0.5


def height_limits(z, percentile: float = HEIGHT_PERCENTILE) -> tuple[float, float, str]:
    """(vmin, vmax, colorbar extend) for a height colour map: the percentile range, not min..max.

    On the paper presets a few corner cells hold 3 m of the 3.84 m relief (see
    :mod:`offroadbench.analysis.relief`); min..max limits would paint the rest of the map one colour.
    ``extend`` is "both", "min", "max" or "neither", as matplotlib's ``colorbar(extend=...)`` takes it.
    """
    z_min, z_max = float(np.min(z)), float(np.max(z))
    lo, hi = (float(v) for v in np.percentile(z, [percentile, 100 - percentile]))
    if not hi > lo:  # (nearly) flat: fall back to the full range, or a 1 m window around a flat map
        return (z_min, z_max, "neither") if z_max > z_min else (z_min - 0.5, z_min + 0.5, "neither")
    extend = {(True, True): "both", (True, False): "min", (False, True): "max", (False, False): "neither"}
    return lo, hi, extend[(z_min < lo, z_max > hi)]

#: The paper's Fig. 4 colours (Majhor & Bos 2023): low blue, semi orange, high yellow.
CLASS_COLOURS = ("#1f5fbf", "#f08c1a", "#f5e52a")


def class_cmap() -> ListedColormap:
    """A colour map of the three roughness classes (0 low, 1 semi, 2 high)."""
    return ListedColormap(CLASS_COLOURS, name="roughness")


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **subplot_kw):
    """A constrained-layout :class:`Figure` and its axes (pyplot-free)."""
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, **subplot_kw)
    return fig, axes


def draw_classes(ax, classes, extent_m) -> None:
    """The class map on ``ax`` with ``origin="lower"`` (x east, y north, metres)."""
    ax.imshow(classes, cmap=class_cmap(), vmin=-0.5, vmax=2.5, origin="lower", extent=extent_m,
              interpolation="nearest")


def draw_border(ax, extent_m, border_m: float, **style) -> None:
    """A rectangle ``border_m`` inside the map's edge (the mission border of Majhor & Bos 2023, Sec. 2.3)."""
    x0, x1, y0, y1 = extent_m
    kw = dict(fill=False, edgecolor="k", linestyle="--", linewidth=1)
    kw.update(style)
    ax.add_patch(Rectangle((x0 + border_m, y0 + border_m), x1 - x0 - 2 * border_m, y1 - y0 - 2 * border_m, **kw))


def class_legend_handles(fractions: dict[str, float] | None = None) -> list[Patch]:
    """Legend patches for the three classes, optionally labelled with their area fractions."""
    handles = []
    for name, colour in zip(CLASS_NAMES, CLASS_COLOURS, strict=True):
        label = name if fractions is None else f"{name} {100 * fractions[name]:.1f} %"
        handles.append(Patch(facecolor=colour, edgecolor="k", label=label))
    return handles
