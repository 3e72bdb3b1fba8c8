"""Soil figures: the single-wheel soil check (sinkage, drawbar pull / load and torque / (load x
radius) against slip, the engine rig beside the Wong-Reece integrals and the published slip-sinkage
bands), a study's soft-soil box plots with the soil and gravity of each group, and a terrain's soil
map over its hillshade."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from offroadbench.plots.style import new_figure

__all__ = ["plot_soil_check", "plot_soil_map", "fig_soil", "conditions_text"]

#: soil map colours, by the map's index (index 0, the default soil, first)
SOIL_COLOURS = ("#d9d9d9", "#e6550d", "#3182bd", "#31a354", "#756bb1", "#fdae6b", "#9ecae1", "#a1d99b")


def plot_soil_map(hm, soil_map, title: str = ""):
    """The soil map (offroadbench.terrain.soil_map.SoilMap) over the terrain's hillshade: one colour per
    soil, the legend with each soil's share of the map."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from offroadbench.plots.terrain import hillshade

    n = len(soil_map.soils)
    colours = [SOIL_COLOURS[k % len(SOIL_COLOURS)] for k in range(n)]
    fig, axes = new_figure(1, 1, figsize=(7.0, 6.0))
    ax = np.ravel(axes)[0]
    ax.imshow(hillshade(hm), cmap="gray", origin="lower", extent=hm.extent_m, vmin=0, vmax=1)
    ax.imshow(soil_map.index, cmap=ListedColormap(colours), origin="lower", extent=hm.extent_m, alpha=0.55,
              vmin=-0.5, vmax=n - 0.5, interpolation="nearest")
    shares = soil_map.fractions()
    ax.legend(handles=[Patch(color=c, label=f"{s} ({100 * shares[s]:.1f} %)") for s, c in zip(soil_map.soils, colours,
                                                                                             strict=True)],
              loc="upper right", fontsize=8, framealpha=0.9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or "soil map")
    return fig


def conditions_text(c: Mapping[str, Any]) -> str:
    """``soil lunar-regolith (study), gravity 1.62 m/s^2 (terrain)`` from
    offroadbench.study.report.header.soil_conditions."""
    g = c.get("gravity_m_s2")
    g_text = f"{g:g} m/s^2" if isinstance(g, (int, float)) else "?"
    soil = f"soil {c.get('soil')} ({c.get('soil_source')})"
    if c.get("soil_map"):
        soil += " with the recipe's soil map ([[soil.regions]] / raster; the soil named is its default)"
    return f"{soil}, gravity {g_text} ({c.get('gravity_source')})"


def fig_soil(boxes: Mapping[str, Mapping[str, Mapping[str, Any]]], metrics: Mapping[str, tuple[str, str]],
             conditions: Mapping[str, Mapping[str, Any]] | None = None):
    """Soft soil: box plots of each :data:`offroadbench.study.stats.terrain.SOIL_METRICS` over every trial per
    group driven on soil (offroadbench.study.stats.terrain.soil_boxes); ``conditions`` (group label ->
    offroadbench.study.report.header.soil_conditions) are written under the plots, one line per group."""
    from offroadbench.plots.study import box_plot

    many = max((len(b) for b in boxes.values()), default=0) > 4
    lines = [f"{g}: {conditions_text(c)}" for g, c in (conditions or {}).items()]
    height = (6.0 if many else 3.6) + 0.16 * len(lines)
    fig, axes = new_figure(1, len(metrics), figsize=(5.0 * len(metrics), height))
    for ax, (metric, (title, unit)) in zip(np.ravel(axes), metrics.items(), strict=True):
        box_plot(ax, boxes[metric], f"{title} ({unit})", title)
    fig.suptitle("Soft soil: every trial (successful or not); slip and sinkage over the moving samples", fontsize=10)
    if lines:
        fig.supxlabel("\n".join(lines), fontsize=7, x=0.01, ha="left", family="monospace")
    return fig


def plot_soil_check(rig, model, title: str = "", bands=(), gravity_m_s2: float | None = None):
    """Three panels against slip: the engine rig (markers) beside the Wong-Reece integrals (line);
    ``rig`` and ``model`` are offroadbench.sim.rigs.soil_check.SoilCheck. ``bands`` (published
    sinkage(slip) / sinkage(0) ranges, offroadbench.sim.tyre_laws.terramechanics.SlipSinkageBand) are drawn on
    the sinkage panel scaled by the model's own static sinkage."""
    fig, axes = new_figure(1, 3, figsize=(11.5, 3.6))
    load, arm = rig.load_n, rig.load_n * rig.radius_m
    panels = (
        (axes[0], lambda c: 1000.0 * c.sinkage_m, "sinkage, mm"),
        (axes[1], lambda c: c.drawbar_pull_n / load, "drawbar pull / load"),
        (axes[2], lambda c: c.torque_nm / arm, "torque / (load x radius)"),
    )
    for ax, value, label in panels:
        ax.plot(model.slip, value(model), "-", color="#1f5fbf", label="Wong-Reece integrals")
        ax.plot(rig.slip, value(rig), "o", color="#f08c1a", mfc="none", label="engine rig")
        ax.set_xlabel("slip")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    h0 = 1000.0 * float(model.sinkage_m[0])
    for k, band in enumerate(bands):
        lo, hi = band.ratio_low * h0, band.ratio_high * h0
        axes[0].errorbar([band.slip], [0.5 * (lo + hi)], yerr=[[0.5 * (hi - lo)]], fmt="none", ecolor="#2a9d3a",
                         elinewidth=2.5, capsize=4,
                         label=f"{band.source.split(' (')[0]}: {band.ratio_low:g}-{band.ratio_high:g}x static, "
                               f"{band.wheel}" if k == 0 else None)
    outside = np.zeros(len(rig.slip), dtype=bool)
    for check in (rig, model):
        if getattr(check, "outside_model", None) is not None:
            outside |= np.asarray(check.outside_model, dtype=bool)
    if outside.any():  # the wheel bottomed out there: outside the model, not agreement
        for ax, _, _ in panels:
            for k, s in enumerate(rig.slip[outside]):
                ax.axvspan(s - 0.05, s + 0.05, color="#d62728", alpha=0.12, lw=0,
                           label="outside the model (bottomed out)" if k == 0 else None)
    axes[0].legend(fontsize=7, loc="upper left")
    g = f", gravity {gravity_m_s2:g} m/s^2" if gravity_m_s2 is not None else ""
    fig.suptitle(title or f"{rig.soil}: wheel r = {rig.radius_m:g} m, b = {rig.width_m:g} m, load {load:.1f} N{g}",
                 fontsize=10)
    return fig
