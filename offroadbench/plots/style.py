"""One look for every figure: the class palette of the paper's Fig. 4 and shared drawing helpers.

Figures are built on :class:`matplotlib.figure.Figure` objects (no pyplot state, no backend
choice); the CLI picks the backend and saves them.
"""

from __future__ import annotations

from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from offroadbench.analysis.roughness import CLASS_NAMES

__all__ = ["CLASS_COLOURS", "class_cmap", "new_figure", "draw_border", "class_legend_handles", "draw_classes"]

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
    for name, colour in zip(CLASS_NAMES, CLASS_COLOURS):
        label = name if fractions is None else f"{name} {100 * fractions[name]:.1f} %"
        handles.append(Patch(facecolor=colour, edgecolor="k", label=label))
    return handles
