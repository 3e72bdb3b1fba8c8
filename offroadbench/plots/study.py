"""Figures of a study report (after Majhor & Bos 2023, Figs. 4-7). Each returns a
:class:`matplotlib.figure.Figure`; the caller saves it.

The figures draw what they are given: box plots take the box statistics the report's tables come
from (offroadbench.study.stats.terrain.box_stats), so tables and plots agree exactly, and this module
imports nothing of offroadbench.study (the report imports it, never the other way round)."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import pandas as pd
from matplotlib.patheffects import Normal, Stroke

from offroadbench.analysis.roughness import CLASS_NAMES
from offroadbench.plots.style import CLASS_COLOURS, class_legend_handles, draw_border, draw_classes, new_figure

__all__ = ["fig_class_areas", "fig_success", "fig_metrics", "fig_missions", "fig_replay", "fig_success_vs_level",
           "fig_paths", "short_label"]


#: below this many samples a box plot also shows every sample
SHOW_POINTS_BELOW = 10


def box_plot(ax, groups: Mapping[str, Mapping[str, Any]], ylabel: str, title: str) -> None:
    """Box plots from box statistics (``median``, ``q1``, ``q3``, ``whislo``, ``whishi``, ``fliers``,
    ``n``, ``values``), one per group label, each labelled with its n; a group of fewer than
    SHOW_POINTS_BELOW samples also shows its samples (spread sideways by rank, not at random)."""
    boxes = []
    for i, (label, s) in enumerate(groups.items()):
        if s["n"] == 0:
            s = dict(s, median=np.nan, q1=np.nan, q3=np.nan, whislo=np.nan, whishi=np.nan)
        many = len(groups) > 4  # many groups: the values only, rotated, the axes' names below
        text = f"{_values(label)} (n={s['n']})" if many else f"{short_label(label)}\nn={s['n']}"
        boxes.append({"label": text, "med": s["median"], "q1": s["q1"], "q3": s["q3"],
                      "whislo": s["whislo"], "whishi": s["whishi"], "fliers": s["fliers"]})
        v = np.asarray(s.get("values", ()), dtype=float)
        if 0 < len(v) < SHOW_POINTS_BELOW:
            offsets = np.linspace(-0.12, 0.12, len(v)) if len(v) > 1 else np.zeros(1)
            ax.plot(i + 1 + offsets, v, "o", color="black", ms=3.5, alpha=0.7, zorder=3)
    ax.bxp(boxes, showfliers=True,
           medianprops={"color": "red"},
           boxprops={"color": CLASS_COLOURS[0]},
           whiskerprops={"color": "black", "linestyle": ":"},
           flierprops={"marker": "+", "markeredgecolor": "red", "linestyle": "none"})
    if len(groups) > 4:
        ax.tick_params(axis="x", labelrotation=90, labelsize=7)
        ax.set_xlabel(" / ".join(part.split(" = ", 1)[0] for part in next(iter(groups)).split(", ")), fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)


def _values(label: str) -> str:
    """The values of a group label ``a = 1, b = x`` as ``1 / x``."""
    return " / ".join(part.split(" = ", 1)[-1] for part in label.split(", "))


def short_label(label: str, one_line: bool = False) -> str:
    """A group label without spaces around ``=``, one grid axis per line to fit under a box (or on
    one line, for titles and table cells)."""
    short = label.replace(" = ", "=")
    return short if one_line else short.replace(", ", "\n")


def fig_class_areas(summary: pd.DataFrame):
    """Fig. 5: median area of each class per group (bars)."""
    fig, axes = new_figure(1, 3, figsize=(10, 3.4))
    x = np.arange(len(summary))
    for ax, cls, colour in zip(axes, CLASS_NAMES, CLASS_COLOURS, strict=True):
        ax.bar(x, summary[f"median_area_{cls}_pct"], color=colour, edgecolor="black")
        n = summary["terrains"] if "terrains" in summary else [None] * len(summary)
        ax.set_xticks(x, [short_label(g) + ("" if k is None else f"\nn={int(k)}") for g, k in zip(summary["group"], n, strict=True)],
                      fontsize=8)
        ax.set_title(f"{cls} roughness", fontsize=10)
        ax.set_ylabel("median area (%)")
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Median area of each roughness class (inside the border, before closing)", fontsize=10)
    return fig


def fig_success(boxes: Mapping[str, Mapping[str, Any]]):
    """Fig. 6: box plots of the per-terrain success rate, given per group label as box statistics
    (offroadbench.study.stats.terrain.success_boxes)."""
    fig, ax = new_figure(figsize=(5, 3.6))
    box_plot(ax, boxes, "success rate per terrain (%)", "Success rate (Eq. 5)")
    ax.set_ylim(-3, 103)
    return fig


def fig_metrics(boxes: Mapping[str, Mapping[str, Mapping[str, Any]]], metrics: Mapping[str, tuple[str, str]]):
    """Fig. 7: box plots of the traversal metrics of successful trials per group; ``boxes`` is metric
    -> group label -> box statistics (offroadbench.study.stats.terrain.metric_boxes), ``metrics`` is metric
    -> (title, unit) for the four panels."""
    many = max((len(b) for b in boxes.values()), default=0) > 4  # rotated labels need room
    fig, axes = new_figure(2, 2, figsize=(11, 10) if many else (9, 6.4))
    for ax, (metric, (title, unit)) in zip(axes.ravel(), metrics.items(), strict=True):
        box_plot(ax, boxes[metric], f"{title} ({unit})", title)
    fig.suptitle("Successful trials only", fontsize=10)
    return fig


def fig_missions(hm, classes: np.ndarray, closed: np.ndarray, border_m: float, trials: pd.DataFrame, *, title: str = ""):
    """Fig. 4 (Majhor & Bos 2023): class map, closed class map with the border, and the terrain's
    missions (start green, goal red; line white = success, black = failure).

    ``trials`` holds the terrain's rows (``start_x_m``, ``start_y_m``, ``goal_x_m``, ``goal_y_m``,
    ``success``).
    """
    fig, axes = new_figure(1, 3, figsize=(13, 5.0))
    titles = ("(a) roughness classes", "(b) closed, with the border", "(c) missions")
    for ax, data, sub in zip(axes, (classes, closed, closed), titles, strict=True):
        draw_classes(ax, data, hm.extent_m)
        ax.set_title(sub, fontsize=10)
        ax.set_xlabel("x (m)")
    axes[0].set_ylabel("y (m)")
    draw_border(axes[1], hm.extent_m, border_m, edgecolor="white", linestyle="-", linewidth=1.5)
    for r in trials.itertuples(index=False):
        colour = "white" if r.success else "black"
        axes[2].plot([r.start_x_m, r.goal_x_m], [r.start_y_m, r.goal_y_m], color=colour, lw=1)
        axes[2].plot(r.start_x_m, r.start_y_m, "o", color="limegreen", ms=5, mec="black", mew=0.5)
        axes[2].plot(r.goal_x_m, r.goal_y_m, "o", color="red", ms=5, mec="black", mew=0.5)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def fig_replay(hm, closed: np.ndarray, border_m: float, path_xy: np.ndarray, tel: dict, *, title: str = ""):
    """One trial: the closed class map with the planned path (white, dashed) and the driven path
    (black, ending in a cross), and its time series (height, roll and pitch, commands, distance
    made good along the path)."""
    fig = new_figure(figsize=(13, 6.0))[0]
    fig.clear()
    grid = fig.add_gridspec(4, 2, width_ratios=(1.15, 1.0))
    ax = fig.add_subplot(grid[:, 0])
    draw_classes(ax, closed, hm.extent_m)
    draw_border(ax, hm.extent_m, border_m, edgecolor="white", linestyle="-", linewidth=1.0,
                label=f"mission border ({border_m:g} m)")
    ax.plot(path_xy[:, 0], path_xy[:, 1], color="white", lw=1.5, ls="--", label="planned",
            path_effects=[Stroke(linewidth=3.0, foreground="black"), Normal()])  # seen on the white legend too
    ax.plot(tel["x_m"], tel["y_m"], color="black", lw=1.5, label="driven")
    ax.plot(tel["x_m"][-1], tel["y_m"][-1], "X", color="red", mec="black", ms=9)
    ax.plot(*path_xy[0], "o", color="limegreen", mec="black", ms=7)
    ax.plot(*path_xy[-1], "o", color="red", mec="black", ms=7)
    pad = 3.0
    xs = np.concatenate([path_xy[:, 0], tel["x_m"]])
    ys = np.concatenate([path_xy[:, 1], tel["y_m"]])
    ax.set_xlim(max(xs.min() - pad, 0), min(xs.max() + pad, hm.width_m))
    ax.set_ylim(max(ys.min() - pad, 0), min(ys.max() + pad, hm.height_m))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9, facecolor="0.8")  # the white lines show
    t = tel["t_s"]
    series = (
        (("z_m", "z (m)", 1.0),),
        (("roll_rad", "roll (deg)", 180 / np.pi), ("pitch_rad", "pitch (deg)", 180 / np.pi)),
        (("cmd_v_m_s", "v cmd (m/s)", 1.0), ("cmd_omega_rad_s", "omega cmd (rad/s)", 1.0)),
        (("progress_m", "progress (m)", 1.0),),
    )
    for i, group in enumerate(series):
        sub = fig.add_subplot(grid[i, 1])
        for col, label, scale in group:
            sub.plot(t, tel[col] * scale, label=label, lw=1)
        sub.legend(fontsize=7, loc="upper left")
        sub.grid(alpha=0.3)
        if i == len(series) - 1:
            sub.set_xlabel("t (s)")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def fig_success_vs_level(by: pd.DataFrame, group: str, level: str):
    """Success rate against the difficulty axis, one line per planner, with 95 % Wilson intervals."""
    fig, ax = new_figure(figsize=(6.4, 4.2))
    for g, t in by.groupby(group, sort=True):
        x = t[level].to_numpy(dtype=float)
        y = 100 * t["success_rate"].to_numpy()
        err = np.vstack([y - 100 * t["ci95_low"].to_numpy(), 100 * t["ci95_high"].to_numpy() - y])
        ax.errorbar(x, y, yerr=err, marker="o", capsize=3, label=str(g))
    ax.axhline(50, color="grey", lw=0.8, ls=":")
    ax.set_xlabel(level)
    ax.set_ylabel("success (%)")
    ax.set_ylim(-3, 103)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Success rate per planner (95 % Wilson intervals)", fontsize=10)
    return fig


def fig_paths(hm, closed: np.ndarray, border_m: float, mission, drawn, *, title: str = ""):
    """Planned (dashed) and driven (solid) paths of several planners on one mission over the closed
    class map. ``drawn``: (label, planned (N, 2) or None, driven (M, 2) or None, outcome) tuples."""
    pts = [np.array([mission.start_xy_m, mission.goal_xy_m])]
    pts += [p for _, planned, driven, _ in drawn for p in (planned, driven) if p is not None]
    allp = np.vstack(pts)
    x0, x1 = max(allp[:, 0].min() - 3, 0), min(allp[:, 0].max() + 3, hm.width_m)
    y0, y1 = max(allp[:, 1].min() - 3, 0), min(allp[:, 1].max() + 3, hm.height_m)
    # the figure takes the crop's shape (equal axes), with room for the title and labels
    fig, ax = new_figure(figsize=(9.5, float(np.clip(6.6 * (y1 - y0) / (x1 - x0) + 1.2, 3.2, 9.0))))
    draw_classes(ax, closed, hm.extent_m)
    draw_border(ax, hm.extent_m, border_m, edgecolor="white", linestyle="-", linewidth=1.0,
                label=f"mission border ({border_m:g} m)")
    colours = ("white", "black", "magenta", "cyan", "lime", "red")
    # strict=False: six colours, so the first six paths are drawn (a planner study has at most five arms);
    # fewer paths leave colours unused
    for (label, planned, driven, outcome), colour in zip(drawn, colours, strict=False):
        if planned is not None:
            ax.plot(planned[:, 0], planned[:, 1], color=colour, lw=1.2, ls="--")
        if driven is not None:
            ax.plot(driven[:, 0], driven[:, 1], color=colour, lw=1.8, label=f"{label}: {outcome}")
            ax.plot(driven[-1, 0], driven[-1, 1], "X", color=colour, mec="black", ms=8)
        else:
            ax.plot([], [], color=colour, lw=1.8, label=f"{label}: {outcome} (no telemetry)")
    ax.plot(*mission.start_xy_m, "o", color="limegreen", mec="black", ms=8, label="start")
    ax.plot(*mission.goal_xy_m, "o", color="red", mec="black", ms=8, label="goal")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + class_legend_handles(), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              framealpha=0.9, facecolor="0.8")  # the white line of the first planner shows
    if title:
        ax.set_title(title, fontsize=9)
    return fig
