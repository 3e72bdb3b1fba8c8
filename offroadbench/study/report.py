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
* if the grid has a ``planner.name`` axis (a planner stress test, see offroadbench.study.stress):
  success against the numeric axis per planner with terrain-bootstrap intervals, breaking points
  measured inside the studied levels (isotonic fit, terrain-bootstrap intervals; a logistic fit with
  its goodness of fit for comparison), terrain-level paired tests on the same missions, the paired
  aliasing (``band_limited``) and map-error (``map_noise_m``) arms with the per-terrain variance share
  above Nyquist, outcomes per planner with replay commands for failures, medians of the traversal
  metrics of successes, and a figure of planned and driven paths on one mission over the class map.

The study's ``[analysis]`` plan (offroadbench.study.plan) is computed first, in "Confirmatory
analysis"; every later section is marked "(exploratory)". The header names the code's git commit
and whether its tree was clean, for every session.

Categorical grid axes (planner, vehicle) get no "change between consecutive groups" table.

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
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.plots.soil import conditions_text, fig_soil
from offroadbench.plots.study import fig_class_areas, fig_metrics, fig_missions, fig_success, short_label
from offroadbench.study import stats
from offroadbench.study.results import load, load_meta, load_terrains

__all__ = ["Report", "build_report", "markdown_table"]

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


# ---------------------------------------------------------------------------- figures
def _fig4(meta: dict[str, Any], trials: pd.DataFrame, cell: int, terrain: int):
    """Fig. 4 of one terrain of a run: rebuilt from the run's recipe and seed, then drawn."""
    from offroadbench.seeding import terrain_seed
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.study.spec import CellPlan

    plan = CellPlan.from_meta(meta, cell)
    seed = terrain_seed(meta["study"]["root_seed"], terrain, cell=plan.key)
    prepared = prepare_terrain(plan.recipe(), seed, plan.trial_settings, [])
    hm, maps, rcfg = prepared.hm, prepared.maps, plan.trial_settings.roughness
    t = trials[(trials["cell"] == cell) & (trials["terrain"] == terrain)]
    title = (f"Terrain {terrain} of {short_label(stats.group_labels(meta)[cell], one_line=True)} (seed {seed}); "
             "missions: white = success, black = failure")
    return fig_missions(hm, maps.classes, maps.closed, rcfg.border_m, t, title=title)


# ---------------------------------------------------------------------------- reference
def _direction_agrees(paper: float, ours: float) -> str:
    """``yes``/``no`` if the changes have the same/opposite sign; the paper's zero is its own case."""
    if math.isnan(paper) or math.isnan(ours):
        return "–"
    if paper == 0:
        return "paper: no change"
    return "yes" if np.sign(paper) == np.sign(ours) else "no"


def _reference_sections(ref: dict[str, Any], summary: pd.DataFrame, terrain: pd.DataFrame | None = None,
                        ours_changes: pd.DataFrame | None = None) -> tuple[list[str], dict[str, pd.DataFrame]]:
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
        if ours_changes is not None and "ci95_low" in ours_changes:  # the report's terrain-bootstrap intervals
            ours = ours.merge(ours_changes[["quantity", "from", "to", "ci95_low", "ci95_high"]],
                              on=["quantity", "from", "to"], how="left")
        rows = []
        for name in names:
            mine = ours[ours["quantity"] == name].reset_index(drop=True)
            for i, pair in enumerate(changes[name]):
                if i >= len(mine):
                    break
                p_abs, p_pct = (list(pair) + [math.nan, math.nan])[:2]
                o_abs, o_pct = mine.loc[i, "change"], mine.loc[i, "change_pct"]
                same = _direction_agrees(p_abs, o_abs)
                rows.append({"quantity": name, "step": f"{short_label(mine.loc[i, 'from'], True)} → {short_label(mine.loc[i, 'to'], True)}",
                             "paper change": p_abs, "paper %": p_pct, "ours change": o_abs,
                             **({"ours 95 % low": mine.loc[i, "ci95_low"], "ours 95 % high": mine.loc[i, "ci95_high"]}
                                if "ci95_low" in mine else {}), "ours %": o_pct,
                             "ours median before": mine.loc[i, "median_from"], "ours median after": mine.loc[i, "median_to"],
                             "same direction": same, **_terrain_verdict(terrain, name, mine.loc[i, "from"],
                                                                         mine.loc[i, "to"], p_abs)})
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


def _terrain_verdict(terrain: pd.DataFrame | None, name: str, frm: str, to: str, paper: float) -> dict[str, Any]:
    """The terrain-level columns of one paper claim: our per-terrain change, its Holm p, and whether
    it is significant at the terrain level in the paper's direction."""
    if terrain is None or terrain.empty:
        return {}
    hit = terrain[(terrain["quantity"] == name) & (terrain["from"] == frm) & (terrain["to"] == to)]
    if hit.empty:
        return {"terrains": math.nan, "terrain-level p (Holm)": math.nan, "significant at the terrain level": "–"}
    r = hit.iloc[0]
    if math.isnan(paper) or paper == 0:
        verdict = "–"
    elif not r["significant"]:
        verdict = "no"
    else:
        verdict = "yes" if np.sign(paper) == np.sign(r["mean_change"]) else "no (opposite direction)"
    return {"terrains": int(r["terrains"]), "terrain-level p (Holm)": r["p_holm"],
            "significant at the terrain level": verdict}


def _terrain_changes_section(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str], names: list[str],
                             study: dict[str, Any], pairs: list[tuple[int, int]] | None = None
                             ) -> tuple[list[str], pd.DataFrame]:
    """Changes between groups (consecutive, or ``pairs``) tested with the terrain as the unit
    (stats.terrain_changes)."""
    paired = bool(study.get("paired_terrains", True))
    tab = stats.terrain_changes(trials, terrains, labels, names, paired=paired, pairs=pairs)
    how = ("per-terrain differences (terrain j of every group shares its seed): mean with a 95 % terrain-bootstrap "
           "interval (distinct resamples beside it), terrains up / down, Wilcoxon signed-rank and exact sign-flip p"
           if paired else "per-terrain values of independent groups: difference of means with a bootstrap interval, "
           "Mann-Whitney U p (in the p_wilcoxon column)")
    shown = tab.assign(step=[f"{short_label(a, True)} → {short_label(b, True)}" for a, b in zip(tab["from"], tab["to"])])
    shown = shown[["quantity", "step", *[c for c in tab.columns if c not in ("quantity", "from", "to")]]]
    text = (f"The terrain is the unit ({how}); `p_holm` is Holm's adjustment over every row of this table, "
            "`significant` = p_holm < 0.05. Success rate and areas in points, metrics as per-terrain medians "
            "of successful trials.")
    title = "## Changes at the terrain level" + ("" if pairs is None else ": every group against the first")
    return [title, "", text, "", markdown_table(shown), ""], tab


# ---------------------------------------------------------------------------- confirmatory
def _confirmatory_section(meta: dict[str, Any], trials: pd.DataFrame, terrains: pd.DataFrame
                          ) -> tuple[list[str], pd.DataFrame | None]:
    """The study's analysis plan, computed exactly (offroadbench.study.plan), or the note that it has none."""
    from offroadbench.study.plan import confirmatory_table, stored_plan

    plan = stored_plan(meta)
    head = ["## Confirmatory analysis (the study's plan)", ""]
    if plan is None:
        return head + ["This run stores no analysis plan (`[analysis]`): **every number in this report is "
                       "exploratory**.", ""], None
    tab = confirmatory_table(plan, meta, trials, terrains)
    rule = {"holm": "Holm's step-down adjustment", "bonferroni": "Bonferroni's adjustment"}[plan.multiplicity]
    shown = tab.assign(**{f"{100 * plan.confidence:g} % interval": [f"[{a:.3g}, {b:.3g}]" for a, b in
                                                                   zip(tab["ci_low"], tab["ci_high"])]})
    shown = shown[["comparison", "metric", "stratum", "terrains", "control_mean", "treatment_mean", "effect",
                   f"{100 * plan.confidence:g} % interval", "test", "p", "min_p", "p_adjusted", "reject"]]
    rejected = int(tab["reject"].sum())
    cols = meta.get("columns", {})
    text = (f"Fixed before the run in the study's `[analysis]` table and stored with it; computed exactly as planned. "
            f"{len(tab)} tests; family-wise alpha = {plan.alpha:g} with {rule} over all of them; {rejected} rejected. "
            "Unit: the terrain (per-terrain value of the metric in each cell; effect = mean per-terrain difference, "
            "treatment - control, with a terrain-cluster bootstrap interval that is not adjusted for multiplicity). "
            "`min_p`: the smallest p the test can give with these terrains. Comparisons: "
            + "; ".join(f"**{c.name}** ({', '.join(f'{cols.get(k, k)} = {v}' for k, v in c.treatment.items())} "
                        f"against {', '.join(f'{cols.get(k, k)} = {v}' for k, v in c.control.items())}, {c.metric}, "
                        f"{c.test})" for c in plan.comparisons)
            + ". **Every other number in this report is exploratory** (sections marked so): chosen or read after "
            "the data, not covered by the plan's error rate.")
    return head + [text, "", markdown_table(shown), ""], tab


def _mark_exploratory(lines: list[str]) -> list[str]:
    """Append "(exploratory)" to every section heading after the confirmatory one, except the run's records."""
    out, after = [], False
    for line in lines:
        if line.startswith("## Confirmatory"):
            after = True
        elif after and line.startswith("## ") and not line.startswith(("## Run sessions", "## Platforms")):
            line = line + " (exploratory)"
        out.append(line)
    return out


def _provenance(meta: dict[str, Any]) -> str:
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


def _axis_effects_section(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str],
                          meta: dict[str, Any]) -> tuple[list[str], pd.DataFrame]:
    """Each grid axis's effect within every stratum of the others (each value against the axis's first), at
    the terrain level with intervals: for grids with a categorical axis (engines, soil models)."""
    study = meta["study"]
    cells = {c["index"]: c["values"] for c in meta["cells"]}
    pairs = []
    for axis in study["grid"]:
        key, first = axis["key"], axis["values"][0]
        for i, v in cells.items():
            if v[key] == first:
                continue
            j = next(k for k, w in cells.items() if w == {**v, key: first})
            pairs.append((j, i))
    names = ["success_rate_pct", *stats.METRICS]
    if "mean_slip" in trials and np.isfinite(trials["mean_slip"].astype(float)).any():
        names += list(stats.SOIL_METRICS)
    lines, tab = _terrain_changes_section(trials, terrains, labels, names, study, pairs)
    lines[0] = "## Changes at the terrain level: each axis within the others"
    return lines, tab


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
    from offroadbench.study.results import load_platforms
    from offroadbench.study.spec import CellPlan

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


# ---------------------------------------------------------------------------- faults (issue 30)
def _faults_section(run_dir: str | Path, tables: dict[str, pd.DataFrame]) -> list[str]:
    """The report's list of faulted trials (``faults`` table of the store: no outcome, so no
    statistic counts them); adds ``faults.csv`` to ``tables``. Nothing when there are none."""
    from offroadbench.study.store import Store

    with Store(run_dir) as store:
        rows = store.fault_rows()
    if not rows:
        return []
    df = pd.DataFrame(rows, columns=["cell", "terrain", "mission", "terrain_seed", "mission_seed", "reason", "session"])
    tables["faults.csv"] = df
    return ["## Faults", "",
            f"{len(df)} trial(s) gave no outcome (past the per-trial limit, or the vehicle thrown while settling). "
            "They are not trials of the study: every statistic above and below leaves them out. "
            "`study run --retry-faults` runs them again.", "",
            markdown_table(df[["cell", "terrain", "mission", "reason", "session"]]), ""]


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
        "fig6_success_rate.png": fig_success(stats.success_boxes(per_terrain, labels)),
        "fig7_traversal_metrics.png": fig_metrics(stats.metric_boxes(trials, labels), stats.METRICS),
        "fig4_missions.png": _fig4(meta, trials, *fig4),
    }
    tables = {
        "summary.csv": summary,
        "failures.csv": failures.reset_index(),
        "terrains.csv": terrains.merge(per_terrain, on=["cell", "terrain"], how="left"),
        "sessions.csv": sessions,
    }

    n_total = meta["n_trials"]
    grid = ", ".join(f"`{a['key']}` = {list(a['values'])}" for a in study["grid"]) or "none"
    from offroadbench.study.header import held_fixed, report_title

    fixed = held_fixed(meta)
    tables["held_fixed.csv"] = fixed
    faults = _faults_section(run_dir, tables)
    n_faults = len(tables["faults.csv"]) if "faults.csv" in tables else 0
    confirm_lines, confirm = _confirmatory_section(meta, trials, terrains)
    if confirm is not None:
        tables["confirmatory.csv"] = confirm
    lines = [
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
        f"- recipe: `{study['recipe']}`; root seed {study['root_seed']}; paired terrains: {study['paired_terrains']}",
        f"- study id `{meta['study_id']}`, created {meta['created']} with offroadbench {meta['version']}",
        f"- code: {_provenance(meta)}",
        f"- wall time: **{wall:.0f} s** ({wall / 60:.1f} min) over {len(sessions)} session(s)",
        "",
        "Statistics as in Majhor & Bos 2023, Sec. 2.4: medians, IQR = Q3 - Q1 (Eq. 6), outliers beyond "
        "Q1 - 1.5 IQR or Q3 + 1.5 IQR (Eq. 7-8); quartiles by MATLAB's `prctile` definition (hazen). "
        "Success rate per terrain = successes / trials x 100 (Eq. 5). Traversal metrics are for "
        "successful trials only.",
        "",
        *confirm_lines,
        "## Run sessions",
        "",
        markdown_table(sessions),
        "",
        *faults,
        *_platforms_section(run_dir, meta)[0],
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
    if len(labels) > 1 and len(study["grid"]) == 1 and _numeric(study["grid"][0]["values"]):
        # a categorical axis (planner, vehicle) has no order: no "change between consecutive groups"
        names = ["success_rate_pct", *(f"area_{c}_pct" for c in stats.CLASSES), *stats.METRICS]
        changes = stats.median_changes(summary, names)
        if bool(study.get("paired_terrains", True)):  # terrain-bootstrap intervals of each change
            changes = stats.median_change_intervals(trials, terrains, changes, labels)
        for side in ("from", "to"):  # the sample size behind each median
            changes[f"n_{side}"] = [int(summary.loc[summary["group"] == g, f"n_{q}"].iloc[0])
                                    for g, q in zip(changes[side], changes["quantity"])]
        tables["median_changes.csv"] = changes
        small = int(changes[["n_from", "n_to"]].min().min()) if len(changes) else 0
        lines += ["## Changes of the medians between consecutive groups", "",
                  f"n: terrains (success rate, class areas) or successful trials (metrics) behind each median; "
                  "`ci95_low`/`ci95_high`: a 95 % terrain-bootstrap interval of the change (terrains resampled, "
                  "the same ones in both groups). "
                  f"A median of n < 10 moves by a whole sample's step (one terrain's success rate is a multiple "
                  f"of 100 / missions per terrain %): {'these changes are' if small < 10 else 'changes with small n are'} "
                  "not evidence of an effect on their own; the box plots show every sample where n < 10.", "",
                  markdown_table(changes), ""]
        terrain_lines, tables["terrain_changes.csv"] = _terrain_changes_section(trials, terrains, labels, names, study)
        lines += terrain_lines
    elif len(labels) > 1 and study["grid"] and all(_numeric(a["values"]) for a in study["grid"]):
        # several numeric axes (a sensitivity study): every cell against the first
        names = ["success_rate_pct", *stats.METRICS]
        first = min(labels)
        terrain_lines, tables["terrain_changes.csv"] = _terrain_changes_section(
            trials, terrains, labels, names, study, [(first, c) for c in sorted(labels) if c != first])
        lines += terrain_lines
    elif len(labels) > 1 and "planner.name" not in meta["columns"] and bool(study.get("paired_terrains", True)):
        # a grid with a categorical axis (engine, tyre model): each axis's effect within the others
        terrain_lines, tables["terrain_changes.csv"] = _axis_effects_section(trials, terrains, labels, meta)
        lines += terrain_lines
    lines += ["## Outcomes and failure reasons", "", markdown_table(failures.reset_index()), ""]
    soil = stats.soil_boxes(trials, labels)
    if soil:
        from offroadbench.study.header import soil_conditions

        cond = {labels[c]: soil_conditions(meta, c) for c in sorted(labels) if labels[c] in next(iter(soil.values()))}
        figures["fig8_soil.png"] = fig_soil(soil, stats.SOIL_METRICS, cond)
        rows = [{"metric": f"{title} ({unit})", "group": g, "n": b["n"], "median": b["median"], "Q1": b["q1"],
                 "Q3": b["q3"], "max": float(np.nanmax(b["values"])) if b["n"] else math.nan}
                for m, (title, unit) in stats.SOIL_METRICS.items() for g, b in soil[m].items()]
        lines += ["## Soft soil: slip and sinkage (every trial)", "", "![Soft soil](fig8_soil.png)", "",
                  "Per trial: the mean longitudinal slip of the wheels and the median and 95th percentile of "
                  "the deepest wheel's sinkage, over the samples where the vehicle is driven (Wong-Reece "
                  "terramechanics tyre model; offroadbench.navigation.metrics); the boxes are over every trial "
                  "of the groups driven on soil, failed ones included. Soil and gravity of each group, and "
                  "where each came from (study: the study sets it; terrain: the recipe's [soil] / [body]; "
                  "default):", "", *[f"- {g}: {conditions_text(c)}" for g, c in cond.items()], "",
                  markdown_table(pd.DataFrame(rows)), ""]
    lines += [
        "## One terrain and its missions (Fig. 4)",
        "",
        "![Fig. 4](fig4_missions.png)",
        "",
        "Classes: low (blue), semi (orange), high (yellow). Starts green, goals red.",
        "",
    ]
    stress_lines, stress_figures, stress_tables = planner_sections(meta, trials, run_dir, terrains)
    lines += stress_lines
    figures.update(stress_figures)
    tables.update(stress_tables)
    ref_lines, ref_tables = _reference_sections(study.get("reference", {}), summary, tables.get("terrain_changes.csv"),
                                                tables.get("median_changes.csv"))
    lines += ref_lines
    tables.update(ref_tables)
    lines = _mark_exploratory(lines)
    return Report(markdown="\n".join(lines).rstrip() + "\n", figures=figures, tables=tables)


# ---------------------------------------------------------------------------- planner stress test
def _numeric(values) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _stress_axes(meta: dict[str, Any]) -> tuple[str | None, str | None, list[str]]:
    """(planner column, the level column or None, the other grid columns) of a study with a planner
    axis. The level is the one numeric axis, or the one numeric recipe axis (e.g. ``D_high``) when
    there are several; every other axis (``band_limited``, ``map_noise_m``, ...) is a stratum."""
    columns = meta["columns"]
    axes = meta["study"]["grid"]
    planner = columns.get("planner.name")
    numeric = [a["key"] for a in axes if _numeric(a["values"])]
    if len(numeric) > 1:
        numeric = [k for k in numeric if k.startswith("recipe.")]
    level = columns[numeric[0]] if len(numeric) == 1 else None
    strata = [columns[a["key"]] for a in axes if columns[a["key"]] not in (planner, level)]
    return planner, level, strata


def _replay_examples(trials: pd.DataFrame, group: str, run_dir: str, per_reason: int = 2) -> pd.DataFrame:
    rows = []
    failed = trials[~trials["success"].astype(bool)]
    for (g, reason), t in failed.groupby([group, "failure_reason"], sort=True):
        for r in t.head(per_reason).itertuples(index=False):
            rows.append({group: g, "failure": reason, "trials": len(t),
                         "replay": f"`offroadbench study replay {run_dir} --cell {r.cell} --terrain {r.terrain} "
                                   f"--mission {r.mission} --plot`"})
    return pd.DataFrame(rows)


def _paths_figure(meta: dict[str, Any], run_dir: Path, trials: pd.DataFrame, group: str, level: str | None,
                  strata: Sequence[str] = ()):
    """Planned and driven paths of every planner on one mission (the one whose outcomes differ most
    between planners, at the middle level), over the closed class map."""
    from offroadbench.io.telemetry import load_telemetry
    from offroadbench.plots.study import fig_paths
    from offroadbench.study.runner import telemetry_paths
    from offroadbench.study.spec import CellPlan
    from offroadbench.study.tasks import prepare_cell

    t = trials
    for col in strata:  # one stratum: the first value of every other axis
        t = t[t[col] == t[col].min()]
    if level is not None:
        levels = sorted(t[level].unique())
        t = t[t[level] == levels[len(levels) // 2]]
    spread = t.groupby(["terrain", "mission"])["success"].agg(lambda s: s.astype(float).std(ddof=0))
    terrain, mission = spread.sort_values(ascending=False, kind="stable").index[0]
    rows = t[(t["terrain"] == terrain) & (t["mission"] == mission)]
    first = rows.iloc[0]
    plan = CellPlan.from_meta(meta, int(first["cell"]))
    prepared, _ = prepare_cell(plan, int(first["terrain_seed"]), [(int(mission), int(first["mission_seed"]))])
    hm, closed, m = prepared.hm, prepared.maps.closed, prepared.missions[0]
    drawn = []
    for r in rows.itertuples(index=False):
        tel_p, path_p = telemetry_paths(run_dir, r.cell, r.terrain, r.mission)
        path = driven = None
        if path_p.is_file():
            xy = load_telemetry(path_p)
            path = np.column_stack([xy["x_m"], xy["y_m"]])
        if tel_p.is_file():
            tel = load_telemetry(tel_p)
            driven = np.column_stack([tel["x_m"], tel["y_m"]])
        if driven is None:  # [study] telemetry = "failed" keeps none of a success: re-run it, bit for bit
            from offroadbench.study.tasks import replay_trial

            rec = replay_trial(run_dir, int(r.cell), int(r.terrain), int(r.mission)).record
            path = np.asarray(rec.path_xy) if path is None else path
            driven = np.column_stack([rec.telemetry["x_m"], rec.telemetry["y_m"]])
        drawn.append((str(getattr(r, group)), path, driven, r.failure_reason or "success"))
    where = f"{level} = {first[level]}, " if level else ""
    title = f"Terrain {terrain}, mission {mission} ({where}seed {first['terrain_seed']}): planned (dashed) and driven paths"
    return fig_paths(hm, closed, plan.section("missions").border_m, m, drawn, title=title)


def _advantage_by_stratum(paired: pd.DataFrame, group: str, level: str, strata: list[str]) -> list[str]:
    """Each planner's terrain-level advantage over the baseline per stratum (rows) and level (columns):
    how it changes with, e.g., the planner map's error or the band limit."""
    p = paired[paired[level] != "all"].copy()
    p["cell"] = [f"{d:+.0f} [{lo:+.0f}, {hi:+.0f}]{' *' if sig else ''}" for d, lo, hi, sig in
                 zip(p["terrain_diff_pct"], p["terrain_ci95_low"], p["terrain_ci95_high"], p["significant"])]
    wide = p.pivot_table(index=[group, *strata], columns=level, values="cell", aggfunc="first").reset_index()
    wide.columns = [str(c) if c in (group, *strata) else f"{level} = {c}" for c in wide.columns]
    return ["### Advantage over the baseline per " + " and ".join(f"`{c}`" for c in strata), "",
            "Mean per-terrain success difference in points with its 95 % terrain-bootstrap interval; "
            "`*`: significant at the terrain level (Holm).", "", markdown_table(wide), ""]


#: arms a planner stress test compares within each stratum: column -> (title, what the paired test asks)
_ARMS = {"band_limited": ("Aliasing: band-limited against aliased W-M surface",
                          "whether removing the W-M terms above the grid's Nyquist frequency changes success on the "
                          "same missions"),
         "map_noise_m": ("Map error: degraded against perfect planner map",
                         "whether planning on a map with height error changes success on the same missions")}


def _arm_sections(trials: pd.DataFrame, terrains: pd.DataFrame | None, group: str, level: str | None,
                  strata: Sequence[str]) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """Paired tests of the two values of each arm axis (aliasing, map error) within every other stratum."""
    from offroadbench.study import stress

    lines: list[str] = []
    tables: dict[str, pd.DataFrame] = {}
    for arm, (title, asks) in _ARMS.items():
        if arm not in strata:
            continue
        values = sorted(trials[arm].unique())
        if len(values) != 2:
            continue
        by = [group, *(c for c in strata if c != arm)] + ([level] if level else [])
        tab = stress.arm_table(trials, arm, values[0], values[1], by,
                               terrains=terrains if arm == "band_limited" else None)
        if tab.empty:
            continue
        name = f"{arm}_tests.csv"
        tables[name] = tab
        res = ("`area_high_*_pct`: mean high-roughness class area of each arm's terrains (how much roughness "
               "the band limit removes); `mean_twin_unexplained_var`: the share of the aliased surface's height variance that the "
               "band-limited twin of the same seed does not explain (1 - r^2), i.e. the variance carried by the "
               "terms above the grid's Nyquist frequency, per terrain, averaged over the stratum; `spearman_...`: "
               "its rank correlation with the per-terrain success difference. " if "mean_twin_unexplained_var" in tab
               else "")
        paired_note = ("The arms share every mission (`same_missions` = 1): the test is paired mission by mission "
                       "within terrains." if (tab["same_missions"] == 1).all() else
                       "**The arms do not share their missions** (`same_missions` < 1: each arm drew its missions "
                       "on its own terrain), so the difference mixes the arm's effect with that of the missions; "
                       "set `[study] missions_from` to pair them.")
        lines += [f"### {title}", "",
                  f"Per-terrain success difference ({values[1]} - {values[0]}, points) with a 95 % terrain-bootstrap "
                  f"interval and the exact sign-flip p, within every stratum: {asks}. {paired_note} {res}"
                  f"`p_holm`: Holm over this table's rows ([{name}]({name})).", "", markdown_table(tab), ""]
    return lines, tables


def planner_sections(meta: dict[str, Any], trials: pd.DataFrame, run_dir: str | Path,
                     terrains: pd.DataFrame | None = None) -> tuple[list[str], dict[str, Any], dict[str, pd.DataFrame]]:
    """The planner stress-test part of a report (studies with a ``planner.name`` grid axis)."""
    from offroadbench.plots.study import fig_success_vs_level
    from offroadbench.study import stress

    group, level, strata = _stress_axes(meta)
    if group is None:
        return [], {}, {}
    planners = sorted(trials[group].unique())
    baseline = "straight" if "straight" in planners else planners[0]
    lines = ["## Planner stress test", "",
             f"Planners: {', '.join(f'`{p}`' for p in planners)}; every planner drove the same missions "
             "(same terrain and mission seeds). The unit of the tests is the terrain (the missions of one "
             "terrain are not independent): success rates have terrain-bootstrap intervals (the Wilson "
             "interval, which treats missions as independent, is in planner_success.csv for comparison); "
             "breaking points come from an isotonic fit of success on the level, inside the studied levels "
             "only, with terrain-bootstrap intervals; paired comparisons against "
             f"`{baseline}` test the per-terrain success differences (exact sign-flip and Wilcoxon tests, "
             "Durkalski's cluster-adjusted McNemar, terrain-bootstrap interval), Holm-adjusted over the table.",
             ""]
    figures: dict[str, Any] = {}
    tables: dict[str, pd.DataFrame] = {}
    if level is not None:
        by = stress.success_by_level(trials, group, level, by=strata)
        tables["planner_success.csv"] = by
        figs = []
        for i, (sv, part) in enumerate(by.groupby(strata, sort=True) if strata else [((), by)]):
            name = f"planner_success_{i}.png" if strata else "planner_success.png"
            figures[name] = fig = fig_success_vs_level(part, group, level)
            where = ", ".join(f"{c} = {v}" for c, v in zip(strata, sv if isinstance(sv, tuple) else (sv,)))
            if where:
                fig.axes[0].set_title(f"Success per planner, {where} (95 % terrain bootstrap)", fontsize=10)
            figs.append(f"![success{': ' + where if where else ''}]({name})")
        shown = by.assign(**{"success (%)": 100 * by["success_rate"], "95 % CI low (terrains)": 100 * by["ci95_low"],
                             "95 % CI high (terrains)": 100 * by["ci95_high"]})[[group, *strata, level, "successes", "trials",
                                                                     "success (%)", "95 % CI low (terrains)",
                                                                     "95 % CI high (terrains)"]]
        bp = stress.breaking_points(trials, group, level, by=strata)
        tables["breaking_points.csv"] = bp
        levels = sorted(trials[level].unique())
        bp_shown = pd.DataFrame({**{c: bp[c] for c in [group, *strata]}, f"{level} where success falls below 50 %": [
            stress.describe_breaking_point(p, lo, hi, levels, last, level) for p, lo, hi, last in
            zip(bp["breaking_point"], bp["ci95_low"], bp["ci95_high"], bp["success_at_last"])],
            "resamples not reaching it": bp["not_reached_share"], "terrains": bp["terrains"],
            "logistic (comparison only)": [("–" if math.isnan(v) else f"{v:.3f}" + (" (extrapolated)" if e else ""))
                                           for v, e in zip(bp["logistic_point"], bp["logistic_extrapolated"])],
            "Fieller set": bp["fieller_set"], "logistic fit p": bp["logistic_gof_p"]})
        lines += ["### Success against " + level, "", *figs, "",
                  markdown_table(shown), "",
                  "### Breaking points", "",
                  f"Where success falls below 50 %, measured inside the studied levels ({min(levels):g}-"
                  f"{max(levels):g}) only: an isotonic (non-increasing) fit of success on {level}, interpolated "
                  "between the two studied levels around the crossing, with a 95 % terrain-bootstrap interval "
                  "('not reached up to x': the fit stays at or above 50 % up to the last level, in the share of "
                  "resamples given). The logistic fit (clustered covariance) is shown for comparison only, with "
                  "Fieller's set as the one or two pieces it is and the p of Pearson's goodness of fit over the "
                  "levels (small: the curve does not follow the data); a logistic crossing outside the levels is "
                  "an extrapolation, not a measurement.", "", markdown_table(bp_shown), ""]
    paired = stress.paired_table(trials, group, level, baseline, by=strata)
    if not paired.empty:
        tables["paired_tests.csv"] = paired
        cols = [group, "versus", *strata, level or "level", "terrains", "pairs", "only this", "only baseline",
                "terrain_diff_pct", "terrain_ci95_low", "terrain_ci95_high", "bootstrap_distinct", "p_sign_flip",
                "p_wilcoxon", "p_durkalski", "p_holm", "significant", "mcnemar_p_missions"]
        lines += ["### Paired comparisons on the same missions", "",
                  "Per-terrain success difference in points (mean over terrains, 95 % terrain-bootstrap interval "
                  "and its distinct resamples); `significant`: Holm-adjusted sign-flip p < 0.05. "
                  "`mcnemar_p_missions` treats missions as independent and is shown only for comparison.", "",
                  markdown_table(paired[cols]), ""]
        if strata and level:
            lines += _advantage_by_stratum(paired, group, level, strata)
    arm_lines, arm_tables = _arm_sections(trials, terrains, group, level, strata)
    lines += arm_lines
    tables.update(arm_tables)
    reasons = pd.crosstab(trials[group], trials["failure_reason"].replace("", "success"))
    reasons.columns.name = None
    tables["planner_failures.csv"] = reasons.reset_index()
    lines += ["### Outcomes per planner", "", markdown_table(reasons.reset_index()), ""]
    examples = _replay_examples(trials, group, str(run_dir))
    if not examples.empty:
        tables["replay_examples.csv"] = examples
        lines += ["### Failures to replay", "",
                  "Each command re-runs one trial bit for bit from the run directory and draws it "
                  "(class map, planned and driven paths, time series).", "", markdown_table(examples), ""]
    ok = trials[trials["success"].astype(bool)]
    keys = [group, *strata] + ([level] if level else [])
    rms = ok.groupby(keys, sort=True).agg(n=("success", "size"), **{
        f"median {title} ({unit})": (metric, "median") for metric, (title, unit) in stats.METRICS.items()}).reset_index()
    tables["planner_metrics.csv"] = rms
    lines += ["### Traversal metrics of successful trials (medians)", "", markdown_table(rms), ""]
    try:
        figures["planner_paths.png"] = _paths_figure(meta, Path(run_dir), trials, group, level, strata)
        lines += ["### Planned and driven paths", "", "![paths](planner_paths.png)", ""]
    except (OSError, KeyError, IndexError) as exc:  # a partial run without telemetry: say so, do not fail
        lines += [f"(No path figure: {exc}.)", ""]
    return lines, figures, tables
