"""Figures of a search report, drawn on :class:`matplotlib.figure.Figure` objects (no backend choice)."""

from __future__ import annotations

import itertools
from typing import Mapping

import numpy as np
import pandas as pd

from offroadbench.plots.style import new_figure
from offroadbench.search.estimators import distinct_failures
from offroadbench.search.space import SearchConfig

__all__ = ["fig_failures_vs_trials", "fig_pairwise"]

_METHOD_STYLE = {"falsify": ("tab:red", "-"), "random": ("tab:blue", "--"), "ce-is": ("tab:green", ":"),
                 "uniform": ("tab:purple", "-.")}


def fig_failures_vs_trials(df: pd.DataFrame, cfg: SearchConfig, labels: Mapping[int, str]):
    """Distinct failures found against trials spent, one panel per grid cell, one line per method."""
    groups = sorted(df["group"].unique())
    fig, axes = new_figure(1, len(groups), figsize=(4.2 * len(groups), 3.4), squeeze=False)
    for ax, grp in zip(axes[0], groups, strict=True):
        g = df[(df["group"] == grp) & df["done"]]
        for method, s in g.groupby("method"):
            x = cfg.unit(s[list(cfg.keys)].to_numpy(dtype=float))
            counts = distinct_failures(x, s["failed"].to_numpy(), cfg.distinct_distance)
            colour, style = _METHOD_STYLE.get(method, ("black", "-"))
            ax.step(np.arange(1, len(counts) + 1), counts, where="post", color=colour, linestyle=style,
                    label=f"{method} ({int(s['failed'].sum())} failures)")
        ax.set_xlabel("trials spent")
        ax.set_ylabel("distinct failures found")
        ax.set_title(labels.get(grp, str(grp)), fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def fig_pairwise(df: pd.DataFrame, cfg: SearchConfig, title: str = ""):
    """Failing and passing trials over every pair of searched parameters (one parameter: against the margin)."""
    keys = list(cfg.keys)
    pairs = list(itertools.combinations(range(len(keys)), 2)) or [(0, None)]
    n = len(pairs)
    cols = min(n, 3)
    rows = (n + cols - 1) // cols
    fig, axes = new_figure(rows, cols, figsize=(4.0 * cols, 3.6 * rows), squeeze=False)
    flat = list(axes.ravel())
    for ax, (i, j) in zip(flat, pairs, strict=False):  # the grid may hold more axes than pairs
        for failed, colour, marker, label in ((False, "tab:blue", ".", "passed"), (True, "tab:red", "x", "failed")):
            s = df[df["failed"] == failed]
            y = s["margin"] if j is None else s[keys[j]]
            ax.scatter(s[keys[i]], y, s=14, c=colour, marker=marker, alpha=0.6, label=f"{label} ({len(s)})")
        p = cfg.params[i]
        ax.set_xlim(p.low, p.high)
        ax.set_xlabel(keys[i], fontsize=8)
        if j is None:
            ax.set_ylabel("failure margin")
            ax.axhline(0.0, color="black", lw=0.8)
        else:
            ax.set_ylim(cfg.params[j].low, cfg.params[j].high)
            ax.set_ylabel(keys[j], fontsize=8)
        ax.legend(fontsize=7)
    for ax in flat[n:]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
