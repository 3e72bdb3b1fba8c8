"""The report of a run directory: Markdown, the paper's figures and summary tables.

:func:`build_report` returns a :class:`Report` (text, matplotlib figures, tables); the CLI
writes it (``offroadbench study report DIR``). Contents, after Majhor & Bos Sec. 3:

* Fig. 5: median class areas (low / semi / high, % of the map inside the border) per group;
* Fig. 6: box plots of the per-terrain success rate (Eq. 5) per group;
* Fig. 7: box plots of RMS vertical acceleration, RMS pitch and roll rates and traversal time,
  successful trials only, per group;
* Fig. 4: one terrain's class map, closed class map, and its missions;
* tables of medians, IQR, counts and 1.5 IQR outliers, median changes between groups, failure
  reasons, run sessions (wall time, machine, version);
* if the study has a ``[reference]`` table: the published numbers beside ours.

``[reference]`` keys: ``source`` (text), ``trials`` and ``successes`` (lists, one per cell),
``median_change.<quantity> = [[change, change_pct], ...]`` (one pair per step between
consecutive cells; NaN = not reported) and ``outliers.<quantity> = [count per cell]``.
Quantities are the summary names: ``success_rate_pct``, ``area_<class>_pct`` or a Fig. 7 metric.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import matplotlib
import numpy as np
import pandas as pd

from offroadbench.study import stats

matplotlib.use("Agg")
from offroadbench.study.results import load, load_meta, load_terrains

__all__ = ["Report", "build_report", "markdown_table"]

#: paper colours of the classes (Fig. 4): low blue, semi orange, high yellow
CLASS_COLOURS = ("#1f4fbf", "#f28e2b", "#f2d43b")


@dataclass
class Report:
    """A built report: Markdown text, figures by file name, tables by file name."""

    markdown: str
    figures: dict[str, Any] = field(default_factory=dict)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)


# ---------------------------------------------------------------------------- formatting
def _fmt(v: Any, digits: int = 3) -> str:
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if math.isnan(v):
            return "–"
        return f"{v:.{digits}g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.2e}"
    return str(v)


def markdown_table(df: pd.DataFrame, digits: int = 3) -> str:
    """A GitHub Markdown table of ``df`` (index dropped), numbers to ``digits`` significant digits."""
    head = "| " + " | ".join(map(str, df.columns)) + " |"
    sep = "|" + "|".join("---" for _ in df.columns) + "|"
    body = ["| " + " | ".join(_fmt(v, digits) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([head, sep, *body])


def _pm(med: float, iqr: float) -> str:
    return f"{_fmt(med)} (IQR {_fmt(iqr)})"


# ---------------------------------------------------------------------------- figures
def _bxp(ax, groups: Sequence[str], samples: Sequence[Sequence[float]], ylabel: str, title: str) -> None:
    boxes = []
    for label, values in zip(groups, samples):
        s = stats.box_stats(values)
        if s["n"] == 0:
            s = dict(s, median=np.nan, q1=np.nan, q3=np.nan, whislo=np.nan, whishi=np.nan)
        boxes.append({"label": label, "med": s["median"], "q1": s["q1"], "q3": s["q3"],
                      "whislo": s["whislo"], "whishi": s["whishi"], "fliers": s["fliers"]})
    ax.bxp(boxes, showfliers=True,
           medianprops={"color": "red"},
           boxprops={"color": "#1f4fbf"},
           whiskerprops={"color": "black", "linestyle": ":"},
           flierprops={"marker": "+", "markeredgecolor": "red", "linestyle": "none"})
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)


def _short(label: str) -> str:
    return label.replace(" = ", "=")


def fig_class_areas(summary: pd.DataFrame):
    """Fig. 5: median area of each class per group (bars)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(10, 3.4), constrained_layout=True)
    x = np.arange(len(summary))
    for ax, cls, colour in zip(axes, stats.CLASSES, CLASS_COLOURS):
        ax.bar(x, summary[f"median_area_{cls}_pct"], color=colour, edgecolor="black")
        ax.set_xticks(x, [_short(g) for g in summary["group"]], fontsize=8)
        ax.set_title(f"{cls} roughness", fontsize=10)
        ax.set_ylabel("median area (%)")
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Median area of each roughness class (inside the border, before closing)", fontsize=10)
    return fig


def fig_success(per_terrain: pd.DataFrame, labels: dict[int, str]):
    """Fig. 6: box plots of the per-terrain success rate per group."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.6), constrained_layout=True)
    cells = sorted(labels)
    samples = [per_terrain.loc[per_terrain["cell"] == c, "success_rate_pct"] for c in cells]
    _bxp(ax, [_short(labels[c]) for c in cells], samples, "success rate per terrain (%)", "Success rate (Eq. 5)")
    ax.set_ylim(-3, 103)
    return fig


def fig_metrics(trials: pd.DataFrame, labels: dict[int, str]):
    """Fig. 7: box plots of the traversal metrics of successful trials per group."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(9, 6.4), constrained_layout=True)
    ok = trials[trials["success"].astype(bool)]
    cells = sorted(labels)
    for ax, (metric, (title, unit)) in zip(axes.ravel(), stats.METRICS.items()):
        samples = [ok.loc[ok["cell"] == c, metric] for c in cells]
        _bxp(ax, [_short(labels[c]) for c in cells], samples, f"{title} ({unit})", title)
    fig.suptitle("Successful trials only", fontsize=10)
    return fig


def fig_missions(meta: dict[str, Any], trials: pd.DataFrame, cell: int, terrain: int):
    """Fig. 4: class map, closed class map and the terrain's missions (start green, goal red)."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    from offroadbench.analysis.roughness import classify, close_rough
    from offroadbench.recipe import generate_terrain, recipe_from_dict
    from offroadbench.study.config import build_section
    from offroadbench.study.seeds import terrain_seed

    info = meta["cells"][cell]
    seed = terrain_seed(meta["study"]["root_seed"], info["seed_key"], terrain)
    hm = generate_terrain(recipe_from_dict(info["recipe"]), seed)
    rcfg = build_section("roughness", info["settings"].get("roughness", {}), "report")
    classes = classify(hm, rcfg)
    closed = close_rough(classes, rcfg.closing_radius_m, hm.cell_size_m)
    cmap = ListedColormap(CLASS_COLOURS)
    fig, axes = plt.subplots(1, 3, figsize=(13, 5.0), constrained_layout=True)
    titles = ("(a) roughness classes", "(b) closed, with the border", "(c) missions")
    for ax, data, title in zip(axes, (classes, closed, closed), titles):
        ax.imshow(data, origin="lower", extent=hm.extent_m, cmap=cmap, vmin=-0.5, vmax=2.5, interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x (m)")
    axes[0].set_ylabel("y (m)")
    b = rcfg.border_m
    x0, x1, y0, y1 = hm.extent_m
    axes[1].add_patch(plt.Rectangle((x0 + b, y0 + b), x1 - x0 - 2 * b, y1 - y0 - 2 * b, fill=False, ec="white", lw=1.5))
    t = trials[(trials["cell"] == cell) & (trials["terrain"] == terrain)]
    for r in t.itertuples(index=False):
        colour = "white" if r.success else "black"
        axes[2].plot([r.start_x_m, r.goal_x_m], [r.start_y_m, r.goal_y_m], color=colour, lw=1)
        axes[2].plot(r.start_x_m, r.start_y_m, "o", color="limegreen", ms=5, mec="black", mew=0.5)
        axes[2].plot(r.goal_x_m, r.goal_y_m, "o", color="red", ms=5, mec="black", mew=0.5)
    fig.suptitle(
        f"Terrain {terrain} of {_short(stats.group_labels(meta)[cell])} (seed {seed}); "
        "missions: white = success, black = failure",
        fontsize=10,
    )
    return fig


# ---------------------------------------------------------------------------- reference
def _direction_agrees(paper: float, ours: float) -> str:
    """``yes``/``no`` if the changes have the same/opposite sign; the paper's zero is its own case."""
    if math.isnan(paper) or math.isnan(ours):
        return "–"
    if paper == 0:
        return "paper: no change"
    return "yes" if np.sign(paper) == np.sign(ours) else "no"


def _reference_sections(ref: dict[str, Any], summary: pd.DataFrame) -> tuple[list[str], dict[str, pd.DataFrame]]:
    lines: list[str] = []
    tables: dict[str, pd.DataFrame] = {}
    if not ref:
        return lines, tables
    lines += ["## Side by side with the published numbers", "", f"Source: {ref.get('source', 'reference')}.", ""]
    groups = list(summary["group"])
    if "successes" in ref:
        paper_n = list(ref.get("trials", [math.nan] * len(groups)))
        rows = []
        for i, g in enumerate(groups):
            ps = ref["successes"][i] if i < len(ref["successes"]) else math.nan
            pn = paper_n[i] if i < len(paper_n) else math.nan
            ours_s, ours_n = int(summary["successes"].iloc[i]), int(summary["trials"].iloc[i])
            rows.append({"group": g, "paper successes": f"{ps} / {pn}", "paper %": 100.0 * ps / pn,
                         "ours successes": f"{ours_s} / {ours_n}", "ours %": 100.0 * ours_s / ours_n if ours_n else math.nan})
        df = pd.DataFrame(rows)
        tables["reference_successes.csv"] = df
        lines += ["### Successful trials", "", markdown_table(df), ""]
    changes = ref.get("median_change", {})
    if changes:
        order = ["success_rate_pct", *(f"area_{c}_pct" for c in stats.CLASSES), *stats.METRICS]
        names = sorted((n for n in changes if f"median_{n}" in summary),
                       key=lambda n: order.index(n) if n in order else len(order))
        ours = stats.median_changes(summary, names)
        rows = []
        for name in names:
            mine = ours[ours["quantity"] == name].reset_index(drop=True)
            for i, pair in enumerate(changes[name]):
                if i >= len(mine):
                    break
                p_abs, p_pct = (list(pair) + [math.nan, math.nan])[:2]
                o_abs, o_pct = mine.loc[i, "change"], mine.loc[i, "change_pct"]
                same = _direction_agrees(p_abs, o_abs)
                rows.append({"quantity": name, "step": f"{_short(mine.loc[i, 'from'])} → {_short(mine.loc[i, 'to'])}",
                             "paper change": p_abs, "paper %": p_pct, "ours change": o_abs, "ours %": o_pct,
                             "ours median before": mine.loc[i, "median_from"], "ours median after": mine.loc[i, "median_to"],
                             "same direction": same})
        df = pd.DataFrame(rows)
        tables["reference_median_changes.csv"] = df
        lines += [
            "### Changes of the group medians from one group to the next",
            "",
            "Percent = change / the earlier median. Success rate and class areas change in percentage points "
            "(the paper's wording does not say whether its class-area changes are points or relative).",
            "",
            markdown_table(df),
            "",
        ]
    outliers = ref.get("outliers", {})
    if outliers:
        rows = []
        for name, counts in outliers.items():
            if f"outliers_{name}" not in summary:
                continue
            for i, g in enumerate(groups):
                rows.append({"quantity": name, "group": g, "paper outliers": counts[i] if i < len(counts) else math.nan,
                             "ours outliers": int(summary[f"outliers_{name}"].iloc[i]),
                             "ours n": int(summary[f"n_{name}"].iloc[i])})
        df = pd.DataFrame(rows)
        tables["reference_outliers.csv"] = df
        lines += ["### 1.5 IQR outliers", "", markdown_table(df), ""]
    return lines, tables


# ---------------------------------------------------------------------------- report
def _sessions(meta: dict[str, Any]) -> pd.DataFrame:
    rows = []
    for r in meta["runs"]:
        wall = (r["finished"] - r["started"]) if r["finished"] else math.nan
        rows.append({"session": r["id"], "started (UTC)": time.strftime("%Y-%m-%d %H:%M", time.gmtime(r["started"])),
                     "executor": r["executor"], "workers": r["workers"], "trials run": r["trials_run"],
                     "wall time (s)": wall, "status": r["status"], "machine": r["machine"], "version": r["version"]})
    return pd.DataFrame(rows)


def _summary_tables(summary: pd.DataFrame) -> dict[str, pd.DataFrame]:
    succ = pd.DataFrame({
        "group": summary["group"], "terrains": summary["terrains"],
        "successes / trials": [f"{s} / {t}" for s, t in zip(summary["successes"], summary["trials"])],
        "median success rate (%)": summary["median_success_rate_pct"],
        "IQR (%)": summary["iqr_success_rate_pct"], "outliers": summary["outliers_success_rate_pct"],
    })
    areas = pd.DataFrame({"group": summary["group"]})
    for cls in stats.CLASSES:
        areas[f"{cls}: median %"] = summary[f"median_area_{cls}_pct"]
        areas[f"{cls}: IQR"] = summary[f"iqr_area_{cls}_pct"]
    metrics = []
    for metric, (title, unit) in stats.METRICS.items():
        for _, r in summary.iterrows():
            metrics.append({"metric": f"{title} ({unit})", "group": r["group"], "n": int(r[f"n_{metric}"]),
                            "median": r[f"median_{metric}"], "Q1": r[f"q1_{metric}"], "Q3": r[f"q3_{metric}"],
                            "IQR": r[f"iqr_{metric}"], "outliers": int(r[f"outliers_{metric}"])})
    return {"success": succ, "areas": areas, "metrics": pd.DataFrame(metrics)}


def build_report(run_dir: str | Path, fig4: tuple[int, int] | None = None) -> Report:
    """The report of a run directory. ``fig4`` = (cell, terrain) for Fig. 4 (default: the middle
    cell's first terrain)."""
    from offroadbench.errors import InputError

    meta = load_meta(run_dir)
    trials = load(run_dir)
    terrains = load_terrains(run_dir)
    if trials.empty:
        raise InputError(f"{run_dir}: no finished trials yet; run the study first")
    labels = stats.group_labels(meta)
    study = meta["study"]
    summary = stats.group_summary(trials, terrains, labels)
    per_terrain = stats.terrain_success(trials)
    failures = stats.failure_table(trials, labels)
    tabs = _summary_tables(summary)
    sessions = _sessions(meta)
    wall = float(np.nansum(sessions["wall time (s)"])) if not sessions.empty else math.nan

    if fig4 is None:
        fig4 = (sorted(labels)[len(labels) // 2], int(trials["terrain"].min()))
    if fig4[0] not in labels:
        raise InputError(f"--fig4 cell {fig4[0]} does not exist; cells: {', '.join(map(str, sorted(labels)))}")

    figures = {
        "fig5_class_areas.png": fig_class_areas(summary),
        "fig6_success_rate.png": fig_success(per_terrain, labels),
        "fig7_traversal_metrics.png": fig_metrics(trials, labels),
        "fig4_missions.png": fig_missions(meta, trials, *fig4),
    }
    tables = {
        "summary.csv": summary,
        "failures.csv": failures.reset_index(),
        "terrains.csv": terrains.merge(per_terrain, on=["cell", "terrain"], how="left"),
        "sessions.csv": sessions,
    }

    n_total = meta["n_trials"]
    grid = ", ".join(f"`{a['key']}` = {list(a['values'])}" for a in study["grid"]) or "none"
    lines = [
        f"# Study report: {study['name']}",
        "",
        study.get("description", ""),
        "",
        f"- trials: **{len(trials)} of {n_total}** stored"
        + ("" if len(trials) == n_total else " (**incomplete**: the study has not finished)"),
        f"- grid: {grid}; {study['terrains_per_cell']} terrains per cell, {study['missions_per_terrain']} missions per terrain",
        f"- recipe: `{study['recipe']}`; root seed {study['root_seed']}; paired terrains: {study['paired_terrains']}",
        f"- study id `{meta['study_id']}`, created {meta['created']} with offroadbench {meta['version']}",
        f"- wall time: **{wall:.0f} s** ({wall / 60:.1f} min) over {len(sessions)} session(s)",
        "",
        "Statistics as in Majhor & Bos Sec. 2.4: medians, IQR = Q3 - Q1 (Eq. 6), outliers beyond "
        "Q1 - 1.5 IQR or Q3 + 1.5 IQR (Eq. 7-8); quartiles by MATLAB's `prctile` definition (hazen). "
        "Success rate per terrain = successes / trials x 100 (Eq. 5). Traversal metrics are for "
        "successful trials only.",
        "",
        "## Run sessions",
        "",
        markdown_table(sessions),
        "",
        "## Roughness classes (Fig. 5)",
        "",
        "![Fig. 5](fig5_class_areas.png)",
        "",
        "Area of each class, % of the map inside the border, before the morphological closing.",
        "",
        markdown_table(tabs["areas"]),
        "",
        "## Success rate (Fig. 6)",
        "",
        "![Fig. 6](fig6_success_rate.png)",
        "",
        markdown_table(tabs["success"]),
        "",
        "## Traversal metrics of successful trials (Fig. 7)",
        "",
        "![Fig. 7](fig7_traversal_metrics.png)",
        "",
        markdown_table(tabs["metrics"]),
        "",
    ]
    if len(labels) > 1 and len(study["grid"]) == 1:
        names = ["success_rate_pct", *(f"area_{c}_pct" for c in stats.CLASSES), *stats.METRICS]
        changes = stats.median_changes(summary, names)
        tables["median_changes.csv"] = changes
        lines += ["## Changes of the medians between consecutive groups", "", markdown_table(changes), ""]
    lines += ["## Outcomes and failure reasons", "", markdown_table(failures.reset_index()), ""]
    lines += [
        "## One terrain and its missions (Fig. 4)",
        "",
        "![Fig. 4](fig4_missions.png)",
        "",
        "Classes: low (blue), semi (orange), high (yellow). Starts green, goals red.",
        "",
    ]
    ref_lines, ref_tables = _reference_sections(study.get("reference", {}), summary)
    lines += ref_lines
    tables.update(ref_tables)
    return Report(markdown="\n".join(lines).rstrip() + "\n", figures=figures, tables=tables)
