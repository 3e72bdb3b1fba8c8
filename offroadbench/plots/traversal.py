"""Traversal figures: missions over the class map (paper Fig. 4c), driven trajectories, and the
time series of one trial. Functions return matplotlib Figures; the CLI saves them."""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.lines import Line2D

from offroadbench.heightmap import Heightmap
from offroadbench.plots.style import class_legend_handles, draw_border, draw_classes, new_figure

__all__ = ["plot_missions", "plot_trajectories", "plot_timeseries"]

_OUTCOME_COLOURS = {"": "white", "tipped": "magenta", "stuck": "red", "timeout": "black", "off_map": "cyan",
                    "entrapped": "orange"}


def _class_axes(hm: Heightmap, classes: np.ndarray, border_m: float | None, title: str):
    fig, ax = new_figure(figsize=(7, 6.4))
    draw_classes(ax, classes, hm.extent_m)
    if border_m:
        draw_border(ax, hm.extent_m, border_m)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(wrap_title(title))
    return fig, ax


def wrap_title(title: str, width: int = 72) -> str:
    """A long title (a terrain label with its overrides, engine and gravity) on several lines."""
    return "\n".join(textwrap.wrap(title, width)) or title


def plot_missions(hm: Heightmap, closed_classes: np.ndarray, missions, *, border_m: float | None = None,
                  title: str = "missions"):
    """The closed class map with straight lines from starts (green) to goals (red): paper Fig. 4c."""
    fig, ax = _class_axes(hm, closed_classes, border_m, title)
    for m in missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        ax.plot([sx, gx], [sy, gy], color="k", linewidth=0.8)
        ax.plot(sx, sy, "o", color="limegreen", markeredgecolor="k", markersize=6)
        ax.plot(gx, gy, "o", color="red", markeredgecolor="k", markersize=6)
    handles = class_legend_handles()
    handles += [Line2D([], [], marker="o", linestyle="", color=c, markeredgecolor="k", label=label)
                for c, label in (("limegreen", "start"), ("red", "goal"))]
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def plot_trajectories(hm: Heightmap, closed_classes: np.ndarray, missions, telemetry: dict, results, *,
                      border_m: float | None = None, title: str = "trajectories", paths: dict | None = None,
                      beliefs: dict | None = None):
    """Driven paths over the class map; each ends in a marker coloured by the outcome.

    ``telemetry`` maps mission index -> telemetry columns; ``results`` are the TrialResults;
    ``paths`` (optional) maps mission index -> planned waypoints (N, 2), drawn dotted (default:
    the start-goal line). ``beliefs`` (optional, the ``mast`` sensor's,
    offroadbench.navigation.sensor.Belief) maps mission index -> what the sensor left: the cells
    no mission's sensor ever saw are greyed out, and each believed path is drawn dashed beside the
    true (driven) one.
    """
    fig, ax = _class_axes(hm, closed_classes, border_m, title)
    if beliefs:
        seen = np.zeros(hm.shape, dtype=bool)
        for b in beliefs.values():
            seen |= b.seen
        grey = np.zeros((*hm.shape, 4))
        grey[~seen] = (0.35, 0.35, 0.35, 0.6)
        ax.imshow(grey, origin="lower", extent=hm.extent_m, interpolation="nearest")
        for b in beliefs.values():
            ax.plot(b.trail_xy[:, 0], b.trail_xy[:, 1], color="royalblue", linewidth=1.2, linestyle="--", zorder=5)
    for m, r in zip(missions, results, strict=True):
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        wp = (paths or {}).get(m.index)
        px, py = ([sx, gx], [sy, gy]) if wp is None else (wp[:, 0], wp[:, 1])
        ax.plot(px, py, color="k", linewidth=0.7, linestyle=":")
        ax.plot(sx, sy, "o", color="limegreen", markeredgecolor="k", markersize=5)
        ax.plot(gx, gy, "o", color="red", markeredgecolor="k", markersize=5)
        tel = telemetry.get(m.index)
        if tel is not None:
            ax.plot(tel["x_m"], tel["y_m"], color="k", linewidth=1.2)
            ax.plot(tel["x_m"][-1], tel["y_m"][-1], "X", color=_OUTCOME_COLOURS[r.failure_reason],
                    markeredgecolor="k", markersize=8)
    happened = {r.failure_reason for m, r in zip(missions, results, strict=True) if telemetry.get(m.index) is not None}
    handles = [Line2D([], [], marker="X", linestyle="", color=c, markeredgecolor="k",
                      label=k or "success") for k, c in _OUTCOME_COLOURS.items() if k in happened]  # only outcomes drawn
    handles += [Line2D([], [], color="k", linewidth=0.7, linestyle=":", label="planned"),
                Line2D([], [], color="k", linewidth=1.2, label="driven")]
    if beliefs:
        from matplotlib.patches import Patch

        handles += [Line2D([], [], color="royalblue", linewidth=1.0, linestyle="--", label="believed path"),
                    Patch(facecolor=(0.35, 0.35, 0.35, 0.6), label="never seen")]
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def plot_timeseries(tel: dict, *, title: str = "trial"):
    """Height, roll/pitch, body rates and speed commands of one trial against time."""
    t = tel["t_s"]
    fig, axes = new_figure(4, 1, figsize=(9, 9), sharex=True)
    axes[0].plot(t, tel["z_m"], color="k")
    axes[0].set_ylabel("z (m)")
    axes[1].plot(t, np.degrees(tel["roll_rad"]), label="roll")
    axes[1].plot(t, np.degrees(tel["pitch_rad"]), label="pitch")
    axes[1].set_ylabel("angle (deg)")
    axes[1].legend(loc="upper right", fontsize=8)
    axes[2].plot(t, np.degrees(tel["roll_rate_body_rad_s"]), label="roll rate", linewidth=0.8)
    axes[2].plot(t, np.degrees(tel["pitch_rate_body_rad_s"]), label="pitch rate", linewidth=0.8)
    axes[2].set_ylabel("body rate (deg/s)")
    axes[2].legend(loc="upper right", fontsize=8)
    speed = np.hypot(tel["vx_m_s"], tel["vy_m_s"])
    axes[3].plot(t, tel["cmd_v_m_s"], label="commanded v", color="C2")
    axes[3].plot(t, speed, label="measured horizontal speed", color="k", linewidth=0.8)
    axes[3].plot(t, tel["cmd_omega_rad_s"], label="commanded omega (rad/s)", color="C3", linewidth=0.8)
    axes[3].set_ylabel("m/s, rad/s")
    axes[3].set_xlabel("time (s)")
    axes[3].legend(loc="upper right", fontsize=8)
    fig.suptitle(wrap_title(title, 100))
    return fig
