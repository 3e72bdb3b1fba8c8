"""The planner sections of the study report: a grid with a ``planner.name`` axis (a planner
stress test, see offroadbench.study.stats.stress), with its aliasing and map-error arms, paired tests,
outcomes with replay commands and a figure of planned and driven paths."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.study.stats import terrain as stats
from offroadbench.study.report.format import markdown_table


# ---------------------------------------------------------------------------- planner stress test
def all_numeric(values) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def stress_axes(meta: dict[str, Any]) -> tuple[str | None, str | None, list[str]]:
    """(planner column, the level column or None, the other grid columns) of a study with a planner
    axis. The level is the one numeric axis, or the one numeric recipe axis (e.g. ``D_high``) when
    there are several; every other axis (``band_limited``, ``map_noise_m``, ...) is a stratum."""
    columns = meta["columns"]
    axes = meta["study"]["grid"]
    planner = columns.get("planner.name")
    numeric = [a["key"] for a in axes if all_numeric(a["values"])]
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
    from offroadbench.study.store.results import telemetry_paths
    from offroadbench.study.spec.config import CellPlan
    from offroadbench.study.execution.tasks import prepare_cell

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
            from offroadbench.study.execution.tasks import replay_trial

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
                 zip(p["terrain_diff_pct"], p["terrain_ci95_low"], p["terrain_ci95_high"], p["significant"], strict=True)]
    wide = p.pivot_table(index=[group, *strata], columns=level, values="cell", aggfunc="first").reset_index()
    wide.columns = [str(c) if c in (group, *strata) else f"{level} = {c}" for c in wide.columns]
    return ["### Advantage over the baseline per " + " and ".join(f"`{c}`" for c in strata), "",
            "Mean per-terrain success difference in points with its 95 % terrain-bootstrap interval; "
            "`*`: significant at the terrain level (Holm).", "", markdown_table(wide), ""]


#: the control of an arm whose sorted order is not the README's (``sensor``: mast against the oracle,
#: mast - oracle); other arms: the first of the two sorted values
_CONTROL = {"sensor": "oracle"}
#: arms a planner stress test compares within each stratum: column -> (title, what the paired test asks)
_ARMS = {"band_limited": ("Aliasing: band-limited against aliased W-M surface",
                          "whether removing the W-M terms above the grid's Nyquist frequency changes success on the "
                          "same missions"),
         "map_noise_m": ("Map error: degraded against perfect planner map",
                         "whether planning on a map with height error changes success on the same missions"),
         "sensor": ("Sensing: the mast sensor against the oracle (true map and pose)",
                    "whether planning through the mast sensor (a map built from its returns, a drifting believed "
                    "pose) instead of the true map and pose changes success on the same missions")}


def _arm_sections(trials: pd.DataFrame, terrains: pd.DataFrame | None, group: str, level: str | None,
                  strata: Sequence[str]) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """Paired tests of the two values of each arm axis (aliasing, map error, sensing) within every other stratum."""
    from offroadbench.study.stats import stress

    lines: list[str] = []
    tables: dict[str, pd.DataFrame] = {}
    for arm, (title, asks) in _ARMS.items():
        if arm not in strata:
            continue
        values = sorted(trials[arm].unique())
        if len(values) != 2:
            continue
        if _CONTROL.get(arm) in values:  # (control, treatment)
            values = [_CONTROL[arm], next(v for v in values if v != _CONTROL[arm])]
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


def _level_sections(trials: pd.DataFrame, group: str, level: str,
                    strata: list[str]) -> tuple[list[str], dict[str, Any], dict[str, pd.DataFrame]]:
    """Success against the stress level per planner (figures, terrain-bootstrap intervals), the
    isotonic breaking points inside the studied levels, and the logistic model appendix."""
    from offroadbench.plots.study import fig_success_vs_level
    from offroadbench.study.stats import stress

    figures: dict[str, Any] = {}
    tables: dict[str, pd.DataFrame] = {}
    lines: list[str] = []
    by = stress.success_by_level(trials, group, level, by=strata)
    tables["planner_success.csv"] = by
    figs = []
    for i, (sv, part) in enumerate(by.groupby(strata, sort=True) if strata else [((), by)]):
        name = f"planner_success_{i}.png" if strata else "planner_success.png"
        figures[name] = fig = fig_success_vs_level(part, group, level)
        where = ", ".join(f"{c} = {v}" for c, v in zip(strata, sv if isinstance(sv, tuple) else (sv,), strict=True))
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
        zip(bp["breaking_point"], bp["ci95_low"], bp["ci95_high"], bp["success_at_last"], strict=True)],
        "resamples not reaching it": bp["not_reached_share"], "terrains": bp["terrains"]})
    located = bp[np.isfinite(bp["logistic_point"].astype(float))]
    model = pd.DataFrame({**{c: located[c] for c in [group, *strata]},
                          "logistic crossing": [f"{v:.3f}" for v in located["logistic_point"]],
                          "Fieller 95 % interval": [("–" if math.isnan(a) else f"[{a:.3f}, {b:.3f}]") for a, b in
                                                    zip(located["fieller_low"], located["fieller_high"], strict=True)],
                          "logistic fit p": located["logistic_gof_p"]})
    lines += ["### Success against " + level, "", *figs, "",
              markdown_table(shown), "",
              "### Breaking points", "",
              f"Where success falls below 50 %, measured inside the studied levels ({min(levels):g}-"
              f"{max(levels):g}) only: an isotonic (non-increasing) fit of success on {level}, interpolated "
              "between the two studied levels around the crossing, with a 95 % terrain-bootstrap interval "
              "('not reached up to x': the fit stays at or above 50 % up to the last level, in the share of "
              "resamples given). A model fit (logistic, for comparison only) is in the model appendix below, "
              "where the data locate it.", "", markdown_table(bp_shown), "",
              "### Model appendix: logistic breaking points (comparison only)", "",
              f"A logistic curve of success on {level} (cluster-robust covariance; Fieller 1954 interval; the p of "
              "Pearson's goodness of fit over the levels, small: the curve does not follow the data) is a model, "
              "not a measurement. It is listed only for the groups whose fitted crossing lies inside the studied "
              f"levels, and its Fieller interval only where it is one bounded interval inside them ('–' otherwise: "
              f"the slope is not clearly non-zero, so the data do not locate the crossing); "
              f"{len(bp) - len(located)} of {len(bp)} groups have no crossing inside the levels and are left out "
              "(a crossing outside them would be an extrapolation).", "",
              markdown_table(model) if len(model) else "(none)", ""]
    return lines, figures, tables


def _outcome_sections(trials: pd.DataFrame, run_dir: str | Path, group: str, level: str | None,
                      strata: list[str]) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """Outcomes per planner, failures to replay (one command each) and the traversal metrics of the
    successful trials."""
    tables: dict[str, pd.DataFrame] = {}
    lines: list[str] = []
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
    return lines, tables


def planner_sections(meta: dict[str, Any], trials: pd.DataFrame, run_dir: str | Path,
                     terrains: pd.DataFrame | None = None, paths_figure: bool = True
                     ) -> tuple[list[str], dict[str, Any], dict[str, pd.DataFrame]]:
    """The planner stress-test part of a report (studies with a ``planner.name`` grid axis).
    ``paths_figure``: draw the planned and driven paths (needs the run directory's store and telemetry;
    False for a report re-rendered from a results folder's tables, experiments/rerender.py)."""
    from offroadbench.study.stats import stress

    group, level, strata = stress_axes(meta)
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
        level_lines, figures, tables = _level_sections(trials, group, level, strata)
        lines += level_lines
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
    outcome_lines, outcome_tables = _outcome_sections(trials, run_dir, group, level, strata)
    lines += outcome_lines
    tables.update(outcome_tables)
    if not paths_figure:
        return lines, figures, tables
    try:
        figures["planner_paths.png"] = _paths_figure(meta, Path(run_dir), trials, group, level, strata)
        lines += ["### Planned and driven paths", "", "![paths](planner_paths.png)", ""]
    except (OSError, KeyError, IndexError) as exc:  # a partial run without telemetry: say so, do not fail
        lines += [f"(No path figure: {exc}.)", ""]
    return lines, figures, tables
