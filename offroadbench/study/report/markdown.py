"""The report of a run directory: Markdown, the paper's figures and summary tables.

:func:`build_report` returns a :class:`Report` (text, matplotlib figures, tables); the CLI
writes it (``offroadbench study report DIR``). Contents, after Majhor & Bos 2023, Sec. 3:

* Fig. 5: median class areas (low / semi / high, % of the map inside the border) per group;
* Fig. 6: box plots of the per-terrain success rate (Eq. 5) per group;
* Fig. 7: box plots of RMS vertical acceleration, RMS pitch and roll rates and traversal time,
  successful trials only, per group;
* Fig. 4: one terrain's class map, closed class map, and its missions;
* tables of medians, IQR, counts and 1.5 IQR outliers, median changes between groups, failure
  reasons, run sessions (wall time, machine, version);
* if the study has a ``[reference]`` table: the published numbers beside ours;
* if the grid has a ``planner.name`` axis (a planner stress test, see offroadbench.study.stats.stress):
  success against the numeric axis per planner with terrain-bootstrap intervals, breaking points
  measured inside the studied levels (isotonic fit, terrain-bootstrap intervals; a logistic fit with
  its goodness of fit for comparison), terrain-level paired tests on the same missions, the paired
  aliasing (``band_limited``) and map-error (``map_noise_m``) arms with the per-terrain variance share
  above Nyquist, outcomes per planner with replay commands for failures, medians of the traversal
  metrics of successes, and a figure of planned and driven paths on one mission over the class map.

The study's ``[analysis]`` plan (offroadbench.study.stats.plan) is computed first, in "Confirmatory
analysis"; every later section is marked "(exploratory)". The header names the code's git commit
and whether its tree was clean, for every session.

Categorical grid axes (planner, vehicle) get no "change between consecutive groups" table.

``[reference]`` keys: ``source`` (text), ``trials`` and ``successes`` (lists, one per cell),
``median_change.<quantity> = [[change, change_pct], ...]`` (one pair per step between
consecutive cells; NaN = not reported) and ``outliers.<quantity> = [count per cell]``.
Quantities are the summary names: ``success_rate_pct``, ``area_<class>_pct`` or a Fig. 7 metric.

The sections live beside this module: ``report_paper`` (reference, confirmatory, terrain and axis
changes), ``report_planners`` (the planner stress test) and ``report_format`` (Markdown tables).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.plots.soil import conditions_text, fig_soil
from offroadbench.plots.study import fig_class_areas, fig_metrics, fig_missions, fig_success, short_label
from offroadbench.study.stats import terrain as stats
from offroadbench.study.report.format import markdown_table
from offroadbench.study.report.paper import (
    axis_effects_section,
    confirmatory_section,
    mark_exploratory,
    reference_sections,
    terrain_changes_section,
)
from offroadbench.study.report.planners import all_numeric, planner_sections
from offroadbench.study.store.results import load, load_meta, load_terrains

__all__ = ["Report", "build_report", "markdown_table"]

@dataclass
class Report:
    """A built report: Markdown text, figures by file name, tables by file name."""

    markdown: str
    figures: dict[str, Any] = field(default_factory=dict)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)


# ---------------------------------------------------------------------------- figures
def _fig4(meta: dict[str, Any], trials: pd.DataFrame, cell: int, terrain: int):
    """Fig. 4 of one terrain of a run: rebuilt from the run's recipe and seed, then drawn."""
    from offroadbench.seeding import terrain_seed
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.study.spec.config import CellPlan

    plan = CellPlan.from_meta(meta, cell)
    seed = terrain_seed(meta["study"]["root_seed"], terrain, cell=plan.key)
    prepared = prepare_terrain(plan.recipe(), seed, plan.trial_settings, [])
    hm, maps, rcfg = prepared.hm, prepared.maps, plan.trial_settings.roughness
    t = trials[(trials["cell"] == cell) & (trials["terrain"] == terrain)]
    title = (f"Terrain {terrain} of {short_label(stats.group_labels(meta)[cell], one_line=True)} (seed {seed}); "
             "missions: white = success, black = failure")
    return fig_missions(hm, maps.classes, maps.closed, rcfg.border_m, t, title=title)


def provenance_text(meta: dict[str, Any]) -> str:
    """The code each session ran: git commit and whether the tree was clean (from the recorded version)."""
    seen = []
    for v in [meta.get("version", "")] + [r.get("version") or "" for r in meta.get("runs", [])]:
        if v not in seen:
            seen.append(v)
    parts = []
    for v in seen:
        if "+git." in v:
            commit = v.split("+git.", 1)[1]
            dirty = commit.endswith("-dirty")
            parts.append(f"commit `{commit.removesuffix('-dirty')}`, " + ("**dirty tree** (uncommitted changes)"
                                                                         if dirty else "clean tree"))
        else:
            parts.append(f"offroadbench {v or '?'} (not a git checkout: commit unknown)")
    return "; ".join(dict.fromkeys(parts))


# ---------------------------------------------------------------------------- report
def _sessions(meta: dict[str, Any]) -> pd.DataFrame:
    rows = []
    for r in meta["runs"]:
        wall = (r["finished"] - r["started"]) if r["finished"] else math.nan
        rows.append({"session": r["id"], "started (UTC)": time.strftime("%Y-%m-%d %H:%M", time.gmtime(r["started"])),
                     "executor": r["executor"], "workers": r["workers"], "trials run": r["trials_run"],
                     "wall time (s)": wall, "status": r["status"], "machine": r["machine"], "version": r["version"]})
    return pd.DataFrame(rows)


def _platforms_section(run_dir: str | Path, meta: dict[str, Any]) -> tuple[list[str], pd.DataFrame]:
    """Which platforms the trials ran on, and whether the project's bit-identity promise covers
    each against the one that ran the most (offroadbench.study.fingerprint.identity_promise)."""
    from offroadbench.study.fingerprint import identity_promise
    from offroadbench.study.store.results import load_platforms
    from offroadbench.study.spec.config import CellPlan

    plats = load_platforms(run_dir)
    quantise = "png16"
    for c in meta["cells"]:
        plan = CellPlan(index=c["index"], values=c["values"], key=c["seed_key"], recipe_data=c["recipe"],
                        settings=c["settings"])
        if getattr(plan.recipe().grid, "quantise", "none") == "none":
            quantise = "none"
    first = plats.iloc[0] if len(plats) else None
    covered = []
    for i, r in plats.iterrows():
        if i == 0:
            covered.append("(reference)")
            continue
        ok, why = identity_promise(first["fingerprint"], r["fingerprint"], quantise, first["version"], r["version"])
        covered.append({True: "yes", False: "no", None: "unknown"}[ok] + f": {why}")
    table = plats.drop(columns=["fingerprint", "version"]).assign(**{"bit-identical to the first": covered})
    lines = ["## Platforms", ""]
    if len(plats) <= 1:
        lines += ["All trials ran on one platform.", ""]
    else:
        lines += [f"The trials ran on {len(plats)} platforms (terrain quantise = `{quantise}`). A trial is promised "
                  "to replay bit for bit on another platform only where the last column says yes.", ""]
    lines += [markdown_table(table), ""]
    return lines, table


def _summary_tables(summary: pd.DataFrame) -> dict[str, pd.DataFrame]:
    succ = pd.DataFrame({
        "group": summary["group"], "terrains": summary["terrains"],
        "successes / trials": [f"{s} / {t}" for s, t in zip(summary["successes"], summary["trials"], strict=True)],
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


# ---------------------------------------------------------------------------- faults (issue 30)
def _faults_section(run_dir: str | Path, tables: dict[str, pd.DataFrame]) -> list[str]:
    """The report's list of faulted trials (``faults`` table of the store: no outcome, so no
    statistic counts them); adds ``faults.csv`` to ``tables``. Nothing when there are none."""
    from offroadbench.study.store.store import Store

    with Store(run_dir) as store:
        rows = store.fault_rows()
    if not rows:
        return []
    df = pd.DataFrame(rows, columns=["cell", "terrain", "mission", "terrain_seed", "mission_seed", "reason", "session"])
    tables["faults.csv"] = df
    return ["## Faults", "",
            f"{len(df)} trial(s) gave no outcome (past the per-trial limit, the vehicle thrown while settling, or "
            "a drawn terrain on which no mission can be drawn under the mission rules: then every mission of that "
            "terrain, and the terrain drops out of the paired comparisons of its cells). "
            "They are not trials of the study: every statistic above and below leaves them out. "
            "`study run --retry-faults` runs them again (a terrain without missions stays one).", "",
            markdown_table(df[["cell", "terrain", "mission", "reason", "session"]]), ""]



def _outside_model_line(trials: pd.DataFrame) -> str:
    """One line: how many soil trials had a wheel outside the soil model (bottomed out) and for what
    share of their time (TrialResult.outside_model_fraction; runs from before the column: not recorded)."""
    frac = trials["outside_model_fraction"].astype(float) if "outside_model_fraction" in trials else pd.Series([], dtype=float)
    frac = frac[np.isfinite(frac)]
    if frac.empty:
        return "Outside the soil model (a wheel bottomed out): not recorded in this run."
    some = frac[frac > 0.0]
    return (f"Outside the soil model (a wheel bottomed out at the tables' sinkage cap, its forces not the "
            f"Wong-Reece model's): {len(some)} of {len(frac)} soil trials"
            + (f", for {100 * float(some.median()):.1f} % of their time (median)." if len(some) else "."))

def _dropped_contacts_line(meta: dict[str, Any], trials: pd.DataFrame) -> list[str]:
    """One line for a study with trials on ``mujoco_warp``: how many had a false height-field contact
    dropped (TrialResult.dropped_contacts; docs/mujoco-warp.md, 'Not done' item 5) and their outcomes;
    runs from before the column: not recorded. Nothing for a study on the other engines."""
    from offroadbench.study.report.header import cell_engine

    warp = [c for c in sorted(set(trials["cell"])) if cell_engine(meta, int(c)) == "mujoco_warp"]
    if not warp:
        return []
    on = trials[trials["cell"].isin(warp)]
    counts = on["dropped_contacts"].astype(float) if "dropped_contacts" in on else pd.Series([], dtype=float)
    counts = counts[np.isfinite(counts)]
    head = ("MuJoCo Warp's false height-field contacts (taken out of its solver, `dropped_contacts`; "
            "docs/mujoco-warp.md, 'Not done' item 5): ")
    if counts.empty:
        return [head + f"not recorded in this run ({len(on)} MuJoCo Warp trials).", ""]
    hit = on.loc[counts.index[counts > 0]]
    outcomes = hit["failure_reason"].replace("", "success").value_counts().sort_index()
    unrecorded = f" ({len(on) - len(counts)} more from before the count was kept)" if len(counts) < len(on) else ""
    return [head + f"{len(hit)} of {len(counts)} MuJoCo Warp trials{unrecorded} had a contact dropped"
            + (f" ({int(counts.sum())} in all, counted per MuJoCo step; outcomes: " + ", ".join(f"{k} {v}" for k, v in outcomes.items()) + ")."
               if len(hit) else "."), ""]


def _header_lines(meta: dict[str, Any], trials: pd.DataFrame, fixed: pd.DataFrame, sessions: pd.DataFrame,
                  n_faults: int) -> list[str]:
    """The report's title, what ran, the run's facts (trials, grid, seed, provenance, wall time) and
    the statistics' definitions."""
    from offroadbench.study.report.header import report_title

    study = meta["study"]
    wall = float(np.nansum(sessions["wall time (s)"])) if not sessions.empty else math.nan
    grid = ", ".join(f"`{a['key']}` = {list(a['values'])}" for a in study["grid"]) or "none"
    n_total = meta["n_trials"]
    return [
        f"# {report_title(meta)}",
        "",
        study.get("description", ""),
        "",
        "What ran (the first cell's resolved settings; `grid axis` where a setting varied):",
        "",
        markdown_table(fixed),
        "",
        f"- trials: **{len(trials)} of {n_total}** stored"
        + (f", {n_faults} fault(s) (no outcome; listed under Faults, in no statistic)" if n_faults else "")
        + ("" if len(trials) + n_faults >= n_total else " (**incomplete**: the study has not finished)"),
        f"- grid: {grid}; {study['terrains_per_cell']} terrains per cell, {study['missions_per_terrain']} missions per terrain",
        f"- recipe: `{study['recipe']}`; root seed {study['root_seed']} "
        + ("(**blind**: the hash of the `[analysis]` plan and the design, so no terrain of this study existed "
           "before its plan was fixed)" if study.get("blind_seed") else "(chosen by hand: **not blind**)")
        + f"; paired terrains: {study['paired_terrains']}",
        f"- study id `{meta['study_id']}`, created {meta['created']} with offroadbench {meta['version']}",
        f"- code: {provenance_text(meta)}",
        f"- wall time: **{wall:.0f} s** ({wall / 60:.1f} min) over {len(sessions)} session(s)",
        "",
        "Statistics as in Majhor & Bos 2023, Sec. 2.4: medians, IQR = Q3 - Q1 (Eq. 6), outliers beyond "
        "Q1 - 1.5 IQR or Q3 + 1.5 IQR (Eq. 7-8); quartiles by MATLAB's `prctile` definition (hazen). "
        "Success rate per terrain = successes / trials x 100 (Eq. 5). Traversal metrics are for "
        "successful trials only.",
        "",
    ]


def _paper_figure_sections(tabs: dict[str, pd.DataFrame]) -> list[str]:
    """The sections of the paper's Figs. 5-7: class areas, success rate, traversal metrics."""
    return [
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


def _median_changes_section(trials: pd.DataFrame, terrains: pd.DataFrame, summary: pd.DataFrame,
                            labels: dict[int, str], study: dict[str, Any],
                            names: list[str]) -> tuple[list[str], pd.DataFrame]:
    """The changes of the medians between consecutive groups of one numeric axis, with the sample size
    behind each median and (paired terrains) a terrain-bootstrap interval."""
    changes = stats.median_changes(summary, names)
    if bool(study.get("paired_terrains", True)):  # terrain-bootstrap intervals of each change
        changes = stats.median_change_intervals(trials, terrains, changes, labels)
    for side in ("from", "to"):  # the sample size behind each median
        changes[f"n_{side}"] = [int(summary.loc[summary["group"] == g, f"n_{q}"].iloc[0])
                                for g, q in zip(changes[side], changes["quantity"], strict=True)]
    small = int(changes[["n_from", "n_to"]].min().min()) if len(changes) else 0
    return ["## Changes of the medians between consecutive groups", "",
            f"n: terrains (success rate, class areas) or successful trials (metrics) behind each median; "
            "`ci95_low`/`ci95_high`: a 95 % terrain-bootstrap interval of the change (terrains resampled, "
            "the same ones in both groups). "
            f"A median of n < 10 moves by a whole sample's step (one terrain's success rate is a multiple "
            f"of 100 / missions per terrain %): {'these changes are' if small < 10 else 'changes with small n are'} "
            "not evidence of an effect on their own; the box plots show every sample where n < 10.", "",
            markdown_table(changes), ""], changes


def _group_change_sections(meta: dict[str, Any], trials: pd.DataFrame, terrains: pd.DataFrame,
                           summary: pd.DataFrame, labels: dict[int, str]) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """The exploratory comparisons of the grid's groups, by the grid's shape: one numeric axis
    (consecutive groups), several numeric axes (every cell against the first) or a categorical axis
    other than the planner (each axis's effect within the others). Nothing for one group."""
    study = meta["study"]
    lines: list[str] = []
    tables: dict[str, pd.DataFrame] = {}
    if len(labels) > 1 and len(study["grid"]) == 1 and all_numeric(study["grid"][0]["values"]):
        # a categorical axis (planner, vehicle) has no order: no "change between consecutive groups"
        names = ["success_rate_pct", *(f"area_{c}_pct" for c in stats.CLASSES), *stats.METRICS]
        lines, tables["median_changes.csv"] = _median_changes_section(trials, terrains, summary, labels, study, names)
        terrain_lines, tables["terrain_changes.csv"] = terrain_changes_section(trials, terrains, labels, names, study)
        lines += terrain_lines
    elif len(labels) > 1 and study["grid"] and all(all_numeric(a["values"]) for a in study["grid"]):
        # several numeric axes (a sensitivity study): every cell against the first
        names = ["success_rate_pct", *stats.METRICS]
        first = min(labels)
        lines, tables["terrain_changes.csv"] = terrain_changes_section(
            trials, terrains, labels, names, study, [(first, c) for c in sorted(labels) if c != first])
    elif len(labels) > 1 and "planner.name" not in meta["columns"] and bool(study.get("paired_terrains", True)):
        # a grid with a categorical axis (engine, tyre model): each axis's effect within the others
        lines, tables["terrain_changes.csv"] = axis_effects_section(trials, terrains, labels, meta)
    return lines, tables


def _soil_section(meta: dict[str, Any], trials: pd.DataFrame,
                  labels: dict[int, str]) -> tuple[list[str], dict[str, Any]]:
    """Slip and sinkage of the groups driven on soft soil (Fig. 8), with each group's soil and gravity;
    nothing when no trial ran on soil."""
    soil = stats.soil_boxes(trials, labels)
    if not soil:
        return [], {}
    from offroadbench.study.report.header import soil_conditions

    cond = {labels[c]: soil_conditions(meta, c) for c in sorted(labels) if labels[c] in next(iter(soil.values()))}
    rows = [{"metric": f"{title} ({unit})", "group": g, "n": b["n"], "median": b["median"], "Q1": b["q1"],
             "Q3": b["q3"], "max": float(np.nanmax(b["values"])) if b["n"] else math.nan}
            for m, (title, unit) in stats.SOIL_METRICS.items() for g, b in soil[m].items()]
    lines = ["## Soft soil: slip and sinkage (every trial)", "", "![Soft soil](fig8_soil.png)", "",
             "Per trial: the mean longitudinal slip of the wheels and the median and 95th percentile of "
             "the deepest wheel's sinkage, over the samples where the vehicle is driven (Wong-Reece "
             "terramechanics tyre model; offroadbench.navigation.metrics); the boxes are over every trial "
             "of the groups driven on soil, failed ones included. Soil and gravity of each group, and "
             "where each came from (study: the study sets it; terrain: the recipe's [soil] / [body]; "
             "default):", "", *[f"- {g}: {conditions_text(c)}" for g, c in cond.items()], "",
             markdown_table(pd.DataFrame(rows)), "", _outside_model_line(trials), ""]
    return lines, {"fig8_soil.png": fig_soil(soil, stats.SOIL_METRICS, cond)}


def _fig4_key(labels: dict[int, str], trials: pd.DataFrame, fig4: tuple[int, int] | None) -> tuple[int, int]:
    """(cell, terrain) of Fig. 4: ``fig4`` checked, or the middle cell's first terrain."""
    from offroadbench.errors import InputError

    if fig4 is None:
        return sorted(labels)[len(labels) // 2], int(trials["terrain"].min())
    if fig4[0] not in labels:
        raise InputError(f"--fig4 cell {fig4[0]} does not exist; cells: {', '.join(map(str, sorted(labels)))}")
    return fig4


def build_report(run_dir: str | Path, fig4: tuple[int, int] | None = None) -> Report:
    """The report of a run directory. ``fig4`` = (cell, terrain) for Fig. 4 (default: the middle
    cell's first terrain)."""
    from offroadbench.errors import InputError
    from offroadbench.study.report.header import held_fixed

    meta = load_meta(run_dir)
    trials = load(run_dir)
    terrains = load_terrains(run_dir)
    if trials.empty:
        raise InputError(f"{run_dir}: no finished trials yet; run the study first")
    labels = stats.group_labels(meta)
    summary = stats.group_summary(trials, terrains, labels)
    per_terrain = stats.terrain_success(trials)
    failures = stats.failure_table(trials, labels)
    sessions = _sessions(meta)
    fig4 = _fig4_key(labels, trials, fig4)
    figures = {
        "fig5_class_areas.png": fig_class_areas(summary),
        "fig6_success_rate.png": fig_success(stats.success_boxes(per_terrain, labels)),
        "fig7_traversal_metrics.png": fig_metrics(stats.metric_boxes(trials, labels), stats.METRICS),
        "fig4_missions.png": _fig4(meta, trials, *fig4),
    }
    fixed = held_fixed(meta)
    tables = {
        "summary.csv": summary,
        "failures.csv": failures.reset_index(),
        "terrains.csv": terrains.merge(per_terrain, on=["cell", "terrain"], how="left"),
        "sessions.csv": sessions,
        "held_fixed.csv": fixed,
    }
    faults = _faults_section(run_dir, tables)
    confirm_lines, confirm = confirmatory_section(meta, trials, terrains, [Path(run_dir)])
    if confirm is not None:
        tables["confirmatory.csv"] = confirm
        if "engine_verdicts" in confirm.attrs:
            tables["engine_verdicts.csv"] = confirm.attrs.pop("engine_verdicts")
    n_faults = len(tables["faults.csv"]) if "faults.csv" in tables else 0
    lines = [*_header_lines(meta, trials, fixed, sessions, n_faults), *confirm_lines,
             "## Run sessions", "", markdown_table(sessions), "", *faults, *_platforms_section(run_dir, meta)[0],
             *_paper_figure_sections(_summary_tables(summary))]
    change_lines, change_tables = _group_change_sections(meta, trials, terrains, summary, labels)
    lines += change_lines
    tables.update(change_tables)
    lines += ["## Outcomes and failure reasons", "", markdown_table(failures.reset_index()), "",
              *_dropped_contacts_line(meta, trials)]
    soil_lines, soil_figures = _soil_section(meta, trials, labels)
    lines += soil_lines
    figures.update(soil_figures)
    lines += ["## One terrain and its missions (Fig. 4)", "", "![Fig. 4](fig4_missions.png)", "",
              "Classes: low (blue), semi (orange), high (yellow). Starts green, goals red.", ""]
    stress_lines, stress_figures, stress_tables = planner_sections(meta, trials, run_dir, terrains)
    lines += stress_lines
    figures.update(stress_figures)
    tables.update(stress_tables)
    ref_lines, ref_tables = reference_sections(meta["study"].get("reference", {}), summary,
                                               tables.get("terrain_changes.csv"), tables.get("median_changes.csv"))
    lines += ref_lines
    tables.update(ref_tables)
    lines = mark_exploratory(lines)
    return Report(markdown="\n".join(lines).rstrip() + "\n", figures=figures, tables=tables)
