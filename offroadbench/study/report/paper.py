"""The sections of the study report that test claims: the published numbers beside ours
(``[reference]``), the confirmatory analysis plan, the terrain-level changes between groups and
the effects of each grid axis."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.plots.study import short_label
from offroadbench.study.stats import terrain as stats
from offroadbench.study.report.format import markdown_table


# ---------------------------------------------------------------------------- reference
def _direction_agrees(paper: float, ours: float) -> str:
    """``yes``/``no`` if the changes have the same/opposite sign; the paper's zero is its own case."""
    if math.isnan(paper) or math.isnan(ours):
        return "–"
    if paper == 0:
        return "paper: no change"
    return "yes" if np.sign(paper) == np.sign(ours) else "no"


def _reference_successes(ref: dict[str, Any], summary: pd.DataFrame) -> pd.DataFrame:
    """The paper's successful trials per group beside ours."""
    groups = list(summary["group"])
    paper_n = list(ref.get("trials", [math.nan] * len(groups)))
    rows = []
    for i, g in enumerate(groups):
        ps = ref["successes"][i] if i < len(ref["successes"]) else math.nan
        pn = paper_n[i] if i < len(paper_n) else math.nan
        ours_s, ours_n = int(summary["successes"].iloc[i]), int(summary["trials"].iloc[i])
        rows.append({"group": g, "paper successes": f"{ps} / {pn}", "paper %": 100.0 * ps / pn,
                     "ours successes": f"{ours_s} / {ours_n}", "ours %": 100.0 * ours_s / ours_n if ours_n else math.nan})
    return pd.DataFrame(rows)


def _reference_changes(changes: dict[str, Any], summary: pd.DataFrame, terrain: pd.DataFrame | None,
                       ours_changes: pd.DataFrame | None) -> pd.DataFrame:
    """The paper's changes of the group medians from one group to the next beside ours (with our
    terrain-bootstrap intervals where the report has them) and the terrain-level verdict."""
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
    return pd.DataFrame(rows)


def _reference_outliers(outliers: dict[str, Any], summary: pd.DataFrame) -> pd.DataFrame:
    """The paper's 1.5 IQR outlier counts per quantity and group beside ours."""
    rows = []
    for name, counts in outliers.items():
        if f"outliers_{name}" not in summary:
            continue
        for i, g in enumerate(summary["group"]):
            rows.append({"quantity": name, "group": g, "paper outliers": counts[i] if i < len(counts) else math.nan,
                         "ours outliers": int(summary[f"outliers_{name}"].iloc[i]),
                         "ours n": int(summary[f"n_{name}"].iloc[i])})
    return pd.DataFrame(rows)


def reference_sections(ref: dict[str, Any], summary: pd.DataFrame, terrain: pd.DataFrame | None = None,
                        ours_changes: pd.DataFrame | None = None) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """The report's side-by-side with a study's ``[reference]`` (the published successes, changes of
    the medians and outlier counts) and the tables it writes; nothing without a reference."""
    lines: list[str] = []
    tables: dict[str, pd.DataFrame] = {}
    if not ref:
        return lines, tables
    lines += ["## Side by side with the published numbers", "", f"Source: {ref.get('source', 'reference')}.", ""]
    if "successes" in ref:
        tables["reference_successes.csv"] = df = _reference_successes(ref, summary)
        lines += ["### Successful trials", "", markdown_table(df), ""]
    if ref.get("median_change"):
        tables["reference_median_changes.csv"] = df = _reference_changes(ref["median_change"], summary, terrain,
                                                                         ours_changes)
        lines += ["### Changes of the group medians from one group to the next", "",
                  "Percent = change / the earlier median. Success rate and class areas change in percentage points "
                  "(the paper's wording does not say whether its class-area changes are points or relative).", "",
                  markdown_table(df), ""]
    if ref.get("outliers"):
        tables["reference_outliers.csv"] = df = _reference_outliers(ref["outliers"], summary)
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


def terrain_changes_section(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str], names: list[str],
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
    shown = tab.assign(step=[f"{short_label(a, True)} → {short_label(b, True)}" for a, b in zip(tab["from"], tab["to"], strict=True)])
    shown = shown[["quantity", "step", *[c for c in tab.columns if c not in ("quantity", "from", "to")]]]
    text = (f"The terrain is the unit ({how}); `p_holm` is Holm's adjustment over every row of this table, "
            "`significant` = p_holm < 0.05. Success rate and areas in points, metrics as per-terrain medians "
            "of successful trials.")
    title = "## Changes at the terrain level" + ("" if pairs is None else ": every group against the first")
    return [title, "", text, "", markdown_table(shown), ""], tab


# ---------------------------------------------------------------------------- confirmatory
def confirmatory_section(meta: dict[str, Any], trials: pd.DataFrame, terrains: pd.DataFrame,
                          pilot_dirs: Sequence[str | Path | None] = ()) -> tuple[list[str], pd.DataFrame | None]:
    """The study's analysis plan, computed exactly (offroadbench.study.stats.plan), or the note that it has none.
    ``pilot_dirs``: folders to look for the plan's pilot in (offroadbench.study.stats.power.resolve_pilot)."""
    from offroadbench.study.stats.plan import confirmatory_table, stored_plan
    from offroadbench.study.stats.power import power_column

    plan = stored_plan(meta)
    head = ["## Confirmatory analysis (the study's plan)", ""]
    if plan is None:
        return head + ["This run stores no analysis plan (`[analysis]`): **every number in this report is "
                       "exploratory**.", ""], None
    power = power_column(meta, pilot_dirs)
    tab = confirmatory_table(plan, meta, trials, terrains, power)
    rule = {"holm": "Holm's step-down adjustment", "bonferroni": "Bonferroni's adjustment"}[plan.multiplicity]
    shown = tab.assign(**{f"{100 * plan.confidence:g} % interval": [f"[{a:.3g}, {b:.3g}]" for a, b in
                                                                   zip(tab["ci_low"], tab["ci_high"], strict=True)]})
    shown = shown.assign(power=["–" if not np.isfinite(v) else f"{v:.2f}" for v in tab["power"]],
                         reject=[f"{r} (exploratory)" if e else str(r) for r, e in
                                 zip(tab["reject"], tab["exploratory"], strict=True)])
    shown = shown[["comparison", "metric", "stratum", "terrains", "control_mean", "treatment_mean", "effect",
                   f"{100 * plan.confidence:g} % interval", "test", "p", "min_p", "p_adjusted", "reject", "power"]
                  + (["summary", "effect_other", "p_other"] if "summary" in tab else [])]
    rejected = int(tab["reject"].sum())
    cols = meta.get("columns", {})
    text = (f"Fixed before the run in the study's `[analysis]` table and stored with it; computed exactly as planned. "
            f"{len(tab)} tests; family-wise alpha = {plan.alpha:g} with {rule} over all of them; {rejected} rejected. "
            "Unit: the terrain (per-terrain value of the metric in each cell; effect = mean per-terrain difference, "
            "treatment - control, with a terrain-cluster bootstrap interval that is not adjusted for multiplicity). "
            "`min_p`: the smallest p the test can give with these terrains. "
            + (f"`power`: each test's power at the effect the plan states, simulated before the run from the "
               f"plan's pilot (`{plan.pilot}`) with the exact test and the {plan.multiplicity.title()} step it faces "
               f"(offroadbench.study.stats.power; {plan.power_sims} simulated studies); `study run` refuses a "
               f"test under {plan.min_power:g} unless the plan marks it exploratory. "
               if power is not None else
               "`power`: – (the plan names no pilot" + (f", or its pilot `{plan.pilot}` is not found from here"
                                                        if plan.pilot else ": it was written before plans stated "
                                                        "their power (issue 42), so no power was fixed before "
                                                        "the run and none is computed after it") + "). ")
            + ("`summary`: the plan's per-terrain summary of the metric; `effect_other` and `p_other`: the same "
               "test with the other summary (median or mean), exploratory, in no adjustment. "
               if "summary" in tab else "")
            + "Comparisons: "
            + "; ".join(f"**{c.name}** ({', '.join(f'{cols.get(k, k)} = {v}' for k, v in c.treatment.items())} "
                        f"against {', '.join(f'{cols.get(k, k)} = {v}' for k, v in c.control.items())}, {c.metric}, "
                        f"{c.test})" for c in plan.comparisons)
            + ". **Every other number in this report is exploratory** (sections marked so): chosen or read after "
            "the data, not covered by the plan's error rate.")
    return head + [text, "", markdown_table(shown), "", *_engine_lines(plan, meta, trials, terrains, tab)], tab


def _engine_lines(plan: Any, meta: dict[str, Any], trials: pd.DataFrame, terrains: pd.DataFrame,
                  tab: pd.DataFrame) -> list[str]:
    """The plan's tests on each engine with the cross-engine verdict (stats.engines.engine_table), stored in
    ``tab.attrs["engine_verdicts"]``; nothing for a study on one engine."""
    from offroadbench.study.stats.engines import engine_table

    eng = engine_table(plan, meta, trials, terrains, tab)
    if eng is None:
        return []
    tab.attrs["engine_verdicts"] = eng
    order = eng["engines"].iloc[0]
    shown = eng.assign(**{
        "interval": [f"[{a:.3g}, {b:.3g}]" for a, b in zip(eng["ci_low"], eng["ci_high"], strict=True)],
        f"engine difference ({order})": [f"{d:+.3g} [{a:.3g}, {b:.3g}] ({n} terrains)" for d, a, b, n in zip(
            eng["engine_difference"], eng["engine_difference_low"], eng["engine_difference_high"],
            eng["engine_difference_terrains"], strict=True)]})
    shown = shown[["comparison", "stratum", "engine", "terrains", "effect", "interval", "p_adjusted", "reject",
                   "verdict", f"engine difference ({order})"]]
    lines = [f"- **{c}** ({s}): {v}." for (c, s), v in eng.groupby(["comparison", "stratum"], sort=False)["verdict"].first().items()]
    return ["### The plan on each engine", "",
            "Each planned test on each engine, over the same terrains and missions (terrain j of every cell has one "
            "seed; the engines' tests are one Holm family, above). Verdict: holds on both (rejected on both, in one "
            "direction), on one engine only (which), on neither. Engine difference: per terrain, the test's "
            f"difference on {order.split(' - ')[0]} minus that on {order.split(' - ')[1]}, averaged over the "
            "terrains with both, with its 95 % terrain-bootstrap interval (Efron & Tibshirani 1993); exploratory "
            "(not in the plan's adjustment) ([engine_verdicts.csv](engine_verdicts.csv)).", "",
            markdown_table(shown), "", *lines, ""]


def mark_exploratory(lines: list[str]) -> list[str]:
    """Append "(exploratory)" to every section heading after the confirmatory one, except the run's records."""
    out, after = [], False
    for line in lines:
        if line.startswith("## Confirmatory"):
            after = True
        elif after and line.startswith("## ") and not line.startswith(("## Run sessions", "## Platforms")):
            line = line + " (exploratory)"
        out.append(line)
    return out


def axis_effects_section(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str],
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
    lines, tab = terrain_changes_section(trials, terrains, labels, names, study, pairs)
    lines[0] = "## Changes at the terrain level: each axis within the others"
    return lines, tab
