"""The report of a search run directory: what ran (code version, the analysis plan), the failure
modes found and the falsifier against its baselines, P(failure) by importance sampling beside plain
Monte Carlo judged at the plan's reference, the failure region, and the worst failures to replay.

:func:`search_table` is the tidy table (one row per proposal: its stream, batch, parameters,
likelihood ratio, and its trial's outcome and margin); :func:`stream_summary` and
:func:`estimates` are the numbers; :func:`build_search_report` puts them into a
:class:`~offroadbench.study.report.markdown.Report` (Markdown, figures, CSV tables) that ``search report``
writes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.errors import InputError
from offroadbench.search.estimators import (Estimate, best_is_gain, binned_failure_rate, distinct_failures, is_estimate,
                                           mc_estimate, trials_for_rel_error)
from offroadbench.search.plan import SearchPlan
from offroadbench.search.runner import NO_MISSION, margin_of
from offroadbench.search.space import METHODS, SearchConfig, search_from_dict
from offroadbench.study.spec.config import CellPlan, study_from_dict

__all__ = ["search_table", "stream_summary", "estimates", "first_failures", "build_search_report", "provenance",
           "search_report_html"]

#: how many distinct failures the "trials to the first k" column counts
FIRST_K = 10
#: worst failures listed with their replay commands
WORST = 5


def _analysis_from_meta(meta: dict[str, Any], keys: tuple[str, ...]):
    """The ``[analysis]`` plan stored with the run (in the stored search TOML), or None."""
    import tomllib

    from offroadbench.search.analysis import analysis_from_dict

    text = meta.get("study_toml") or ""
    if not text:
        return None
    return analysis_from_dict(tomllib.loads(text).get("analysis"), keys, where="stored [analysis]")


def _plan_from_meta(meta: dict[str, Any]) -> SearchPlan:
    search_data = dict(meta["search"])
    search_data["params"] = [dict(p) for p in search_data["params"]]
    search = search_from_dict(search_data, where="stored [search]")
    head = ("name", "recipe", "root_seed", "description", "paired_terrains", "telemetry")
    study = study_from_dict({"study": {k: v for k, v in meta["study"].items() if k in head}})
    groups = tuple(CellPlan(index=g["index"], values=g["values"], key=g["seed_key"], recipe_data=g["recipe"],
                            settings=g["settings"]) for g in meta["groups"])
    return SearchPlan(search=search, study=study, groups=groups, analysis=_analysis_from_meta(meta, search.keys))


def provenance(meta: dict[str, Any]) -> str:
    """The code every session of the run ran: the git commit and whether its tree was clean, from
    the versions recorded with the run and each session (offroadbench.study.runner.code_version)."""
    seen: list[str] = []
    for v in [meta.get("version", "")] + [r.get("version") or "" for r in meta.get("runs", [])]:
        if v not in seen:
            seen.append(v)
    parts = []
    for v in seen:
        if "+git." in v:
            commit = v.split("+git.", 1)[1]
            parts.append(f"commit `{commit.removesuffix('-dirty')}`, "
                         + ("**dirty tree** (uncommitted changes)" if commit.endswith("-dirty") else "clean tree"))
        else:
            parts.append(f"offroadbench {v or '?'} (not a git checkout: commit unknown)")
    return "; ".join(dict.fromkeys(parts))


def search_table(run_dir: str | Path) -> tuple[pd.DataFrame, SearchPlan]:
    """One row per stored proposal (run or not) and the search it belongs to."""
    from offroadbench.study.store.search import search_rows
    from offroadbench.study.store.store import Store

    with Store(run_dir) as store:
        meta = store.meta()
        if meta.get("kind") != "search":
            raise InputError(f"{run_dir}: holds a study, not a search (see `study report`)")
        raw = search_rows(store)
    plan = _plan_from_meta(meta)
    cfg = plan.search
    records = []
    for cell, grp, method, batch, slot, stage, x, log_w, row, tseed, mseed in raw:
        xs = json.loads(x)
        values = cfg.values(xs)
        rec: dict[str, Any] = {"cell": cell, "group": grp, "method": method, "batch": batch, "slot": slot,
                               "stage": stage, **values, "log_w": np.nan if log_w is None else log_w,
                               "terrain_seed": tseed, "mission_seed": mseed}
        if row is not None:
            r = json.loads(row)
            rec.update(done=True, failed=not r["success"] and r["failure_reason"] != NO_MISSION,
                       failure_reason=r["failure_reason"],
                       margin=margin_of(plan, plan.groups[grp], values, r),
                       final_distance_to_goal_m=r["final_distance_to_goal_m"])
        else:
            rec.update(done=False, failed=False, failure_reason="", margin=np.nan, final_distance_to_goal_m=np.nan)
        records.append(rec)
    return pd.DataFrame.from_records(records), plan


def _unit(cfg: SearchConfig, df: pd.DataFrame) -> np.ndarray:
    return cfg.unit(df[list(cfg.keys)].to_numpy(dtype=float)) if len(df) else np.zeros((0, cfg.dim))


def first_failures(cfg: SearchConfig, stream: pd.DataFrame, k: int = FIRST_K) -> float:
    """Trials a stream spent until its k-th distinct failure (NaN if it has fewer)."""
    s = stream[stream["done"]]
    counts = distinct_failures(_unit(cfg, s), s["failed"].to_numpy(), cfg.distinct_distance)
    hit = np.nonzero(counts >= k)[0]
    return float(hit[0] + 1) if len(hit) else float("nan")


def stream_summary(df: pd.DataFrame, cfg: SearchConfig) -> pd.DataFrame:
    """Per (group, method): trials, failures, distinct failures, trials to the first FIRST_K distinct failures, best margin."""
    rows = []
    order = {m: i for i, m in enumerate(METHODS)}
    keys = sorted(df.groupby(["group", "method"]).groups, key=lambda k: (k[0], order.get(k[1], len(order))))
    for grp, method in keys:
        s = df[(df["group"] == grp) & (df["method"] == method)]
        s = s[s["done"]]
        counts = distinct_failures(_unit(cfg, s), s["failed"].to_numpy(), cfg.distinct_distance)
        rows.append({"group": grp, "method": method, "trials": len(s), "failures": int(s["failed"].sum()),
                     "no mission": int((s["failure_reason"] == NO_MISSION).sum()),
                     "distinct failures": int(counts[-1]) if len(counts) else 0,
                     "terrains failed": int(s.loc[s["failed"], "terrain_seed"].nunique()),
                     f"trials to {FIRST_K} distinct failures": first_failures(cfg, s),
                     "lowest margin": float(s["margin"].min()) if len(s) else np.nan})
    return pd.DataFrame(rows)


def estimates(df: pd.DataFrame, cfg: SearchConfig) -> dict[tuple[int, str], Estimate]:
    """P(failure) per group: plain Monte Carlo from the ``random`` stream, importance sampling from
    the ``ce-is`` stream's final stage (its adaptive stages counted in ``trials``)."""
    out = {}
    for grp, g in df[df["done"]].groupby("group"):
        rnd = g[g["method"] == "random"]
        if len(rnd):
            out[(grp, "mc")] = mc_estimate(rnd["failed"].to_numpy(), level=cfg.level)
        ce = g[g["method"] == "ce-is"]
        if len(ce):
            final = ce[ce["stage"] == "ce-final"]
            if not len(final):  # the budget ended while adapting: the last stage's draws
                final = ce[ce["batch"] == ce["batch"].max()]
            out[(grp, "ce-is")] = is_estimate(final["failed"].to_numpy(), final["log_w"].to_numpy(), trials=len(ce),
                                              level=cfg.level)
    return out


def _group_label(plan: SearchPlan, grp: int) -> str:
    values = plan.groups[grp].values
    return ", ".join(f"{k} = {v}" for k, v in values.items()) or "all"


def mc_trials_ratio(mc: Estimate, est: Estimate) -> float:
    """How many times fewer trials ``est`` spent than plain Monte Carlo needs for ``est``'s relative
    error at the Monte Carlo estimate ``mc.p``: (1 - p) / (p r^2) / trials (NaN without both)."""
    if not (mc.p > 0 and math.isfinite(est.rel_error) and est.rel_error > 0 and est.trials):
        return float("nan")
    return (1 - mc.p) / (mc.p * est.rel_error ** 2) / est.trials


def _estimate_rows(plan: SearchPlan, ests: dict[tuple[int, str], Estimate]) -> pd.DataFrame:
    rows = []
    for (grp, method), e in sorted(ests.items()):
        rel = e.rel_error if math.isfinite(e.rel_error) else 0.1
        mc = ests.get((grp, "mc"))
        rows.append({"group": _group_label(plan, grp), "estimator": method, "trials": e.trials, "failures": e.failures,
                     "P(failure)": e.p, "relative error": e.rel_error, f"{e.level:.0%} low": e.low,
                     f"{e.level:.0%} high": e.high,
                     "trials for 10 % rel. error": trials_for_rel_error(e, 0.1) if rel else np.nan,
                     "MC trials for this rel. error / trials": mc_trials_ratio(mc, e) if mc is not None else np.nan,
                     "covers MC": (e.low <= mc.p <= e.high) if mc is not None and e is not mc else None})
    return pd.DataFrame(rows)


def is_gain_bounds(df: pd.DataFrame, plan: SearchPlan) -> pd.DataFrame:
    """Per group with a ``random`` stream and per searched parameter: the most importance sampling
    over the parameters could gain over plain Monte Carlo if P(fail | theta) were the failure rate
    binned on that parameter (offroadbench.search.estimators.best_is_gain, binned_failure_rate)."""
    cfg = plan.search
    rows = []
    for grp, g in df[df["done"] & (df["method"] == "random")].groupby("group"):
        z = cfg.to_z(g[list(cfg.keys)].to_numpy(dtype=float))
        failed = g["failed"].to_numpy(dtype=bool)
        for i, key in enumerate(cfg.keys):
            rows.append({"group": _group_label(plan, grp), "parameter": key, "MC trials": len(g),
                         "failures": int(failed.sum()),
                         "best IS gain, failure rate binned on this parameter": best_is_gain(binned_failure_rate(z[:, i], failed))})
    return pd.DataFrame(rows)


def _fmt(v: float, digits: int = 4) -> str:
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}g}"


def _plan_lines(plan: SearchPlan) -> list[str]:
    a = plan.analysis
    if a is None:
        return ["No `[analysis]` plan in the search file: every figure below is exploratory.", ""]
    rows = [("estimand", a.estimand), ("estimator", f"`{a.estimator}`" + (f", {a.interval} interval" if a.estimator == "ce-is" else
                                                                           ", Clopper-Pearson interval")),
            ("reference", f"`{a.reference}`" + (f" (boundary in `{a.boundary_param}`" + (
                f", measured on the trials of `{a.reference_from}`" if a.reference_from else "") + ")"
                if a.boundary_param else "")),
            ("the falsifier's baseline", f"`{a.baseline}`; trials to the k-th failure for k in {list(a.first_k)}"),
            ("stopping rule", "each method its fixed trial budget" if a.stopping == "budget" else a.stopping),
            ("importance-sampling gain", "work-normalised variance ratio at the reference p: p (1 - p) / (N_IS V_IS)"),
            ("level", f"{a.level:.0%}")]
    return ["The analysis plan (`[analysis]`, fixed in the search file before the run and stored with it; the "
            "figures it names are in the next three sections, every other number is exploratory):", "",
            "| item | plan |", "|---|---|", *[f"| {k} | {v} |" for k, v in rows], ""]


def _analysis_sections(df: pd.DataFrame, plan: SearchPlan, run_dir: Path) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """Failure modes, the falsifier against its baselines, and the estimates at the reference (the
    figures the plan names; offroadbench.search.evaluate)."""
    from offroadbench.search import evaluate as ev
    from offroadbench.study.report import markdown_table

    cfg, a = plan.search, plan.analysis
    level = a.level if a else cfg.level
    ks = a.first_k if a else (1, FIRST_K)
    lines = ["## Failure modes", "",
             ("Which searched parameters the failure depends on: the correlation ratio eta^2 of the failure "
              "indicator on 10 equal-count bins of each parameter, over independent draws (the `random` stream, "
              "else `uniform`), against the 99 % quantile of eta^2 over 999 permutations of the failures "
              "(offroadbench.search.modes.sensitivity); a parameter below it is inactive and left out of the modes "
              "(where none is found active, too few failures to tell, every parameter is kept). "
              "A mode: failures chained within the study's distinct distance "
              f"({cfg.distinct_distance:g} of a range) in every active parameter (single linkage)."), ""]
    tables: dict[str, pd.DataFrame] = {}
    sens_rows, mode_rows, stream_rows, count_rows, est_rows = [], [], [], [], []
    ref_lines = []
    for grp in sorted(df["group"].unique()):
        label = _group_label(plan, grp)
        g = df[df["group"] == grp]
        sens, failures, labels, table = ev.modes(g, cfg)
        sens_rows += [{"group": label, "parameter": x.key, "eta^2": x.eta2, "99 % permutation threshold": x.threshold,
                       "p": x.p_value, "active": x.active, "draws": f"{x.draws} ({x.source})", "failures": x.failures}
                      for x in sens]
        for _, r in table.iterrows():
            cell = r["representative cell"]
            mode_rows.append({"group": label, **r.to_dict(),
                              "replay": f"`offroadbench study replay {run_dir} --cell {cell} --terrain 0 --mission 0 "
                                        f"--plot --animate cell{cell}.gif`"})
        for _, r in ev.stream_mode_rows(g, labels).iterrows():
            stream_rows.append({"group": label, **r.to_dict()})
        ref = ev.reference(g, cfg, a, planner=ev.group_planner(plan.groups[grp]))
        counts = ev.falsifier_counts(g, cfg, ks, ref)
        count_rows += [{"group": label, **r.to_dict()} for _, r in counts.iterrows()]
        if ref is not None:
            ref_lines.append(f"- {label}: reference P = **{ref.p:.4g}** ({ref.low:.4g}-{ref.high:.4g}), {ref.how}.")
            pos = ev.mc_position(g, cfg, ref)
            if pos is not None:
                e = pos["estimate"]
                b = ref.boundary
                side = "" if b is None else (f"below {b.low:.4g}" if b.sign > 0 else f"above {-b.low:.4g}")
                why = (f" Of its {e.n} nominal draws, {pos['below']} fell {side}, where every "
                       f"trial fails, against {pos['expected_below']:.1f} the nominal puts there: the estimate sits "
                       f"{'above' if e.p > ref.p else 'below'} the reference by that chance "
                       f"{'excess' if pos['below'] > pos['expected_below'] else 'shortage'} of draws in the failure "
                       "region." if pos["below"] is not None else "")
                ref_lines.append(f"  Plain Monte Carlo: {e.p:.4g} ({e.failures} / {e.n}), {pos['z']:+.2f} of its "
                                 f"standard errors at the reference from it.{why}")
        s = ev.is_summary(g, cfg, ref.p if ref else None, level)
        if s is not None:
            e = s["estimate"]
            est_rows.append({"group": label, "IS P": e.p, "failures / final draws": f"{e.failures} / {e.n}",
                             "trials": e.trials, "normal low": e.low, "normal high": e.high,
                             "bootstrap-t low": s["bootstrap_t"][0], "bootstrap-t high": s["bootstrap_t"][1],
                             "reference P": ref.p if ref else math.nan, "gain at the reference": s["gain"],
                             "normal covers": s["covers_normal"], "bootstrap-t covers": s["covers_bootstrap_t"]})
    lines += [markdown_table(pd.DataFrame(sens_rows)), ""]
    modes_df = pd.DataFrame(mode_rows)
    lines += [(f"**{len(modes_df)} failure mode(s)** over the groups" if len(modes_df) else "**No failure found.**"), ""]
    if len(modes_df):
        lines += [markdown_table(modes_df), ""]
    streams_df = pd.DataFrame(stream_rows)
    lines += ["Each stream's modes and first failure:", "", markdown_table(streams_df), "",
              "## The falsifier against its baselines", "",
              ("Trials each search spent to its k-th failure (and to the largest k's distinct failures under the "
               "study's rule). Baselines: uniform draws on the falsifier's own search box (the naive search; the "
               "primary baseline) and nominal draws, each the median and 10-90 % range over "
               f"{ev.STREAMS} streams: orders of the run's own `uniform` / `random` trials where it has them, else "
               "streams whose outcomes are computed from the measured boundary (offroadbench.search.baselines). "
               "One run holds one falsifier stream; its spread needs repeats (the results' README)."), "",
              markdown_table(pd.DataFrame(count_rows)), "",
              "## The reference, and importance sampling judged at it", ""]
    lines += ref_lines + [""] if ref_lines else ["(no reference: no `random` stream and no boundary plan)", ""]
    est_df = pd.DataFrame(est_rows)
    if len(est_df):
        lines += [("Importance sampling's estimate with its normal and bootstrap-t intervals "
                   "(offroadbench.search.estimators.bootstrap_t_interval) and its gain at the reference, "
                   "p (1 - p) / (N_IS se^2) from this run's stated standard error (one run's figure: the spread "
                   "over repeats is the honest one)."), "", markdown_table(est_df), ""]
    tables.update({"sensitivity.csv": pd.DataFrame(sens_rows), "modes.csv": modes_df, "stream_modes.csv": streams_df,
                   "baselines.csv": pd.DataFrame(count_rows), "is_at_reference.csv": est_df})
    return lines, tables


def build_search_report(run_dir: str | Path):
    """The report of a search run directory (offroadbench.study.report.markdown.Report)."""
    from offroadbench.search.figures import fig_failures_vs_trials, fig_pairwise
    from offroadbench.study.report.markdown import Report, markdown_table

    from offroadbench.study import load_meta

    run_dir = Path(run_dir)
    df, plan = search_table(run_dir)
    meta = load_meta(run_dir)
    done = df[df["done"]]
    if done.empty:
        raise InputError(f"{run_dir}: no finished trials yet; run the search first")
    cfg = plan.search
    summary = stream_summary(df, cfg)
    summary.insert(0, "cell", summary.pop("group").map(lambda g: _group_label(plan, g)))
    ests = estimates(df, cfg)
    est_table = _estimate_rows(plan, ests)
    bounds = is_gain_bounds(df, plan)
    worst = done[done["failed"]].sort_values(["margin", "cell"]).head(WORST)
    analysis_lines, analysis_tables = _analysis_sections(df, plan, run_dir)
    figures = {"failures_vs_trials.png": fig_failures_vs_trials(df, cfg, {g: _group_label(plan, g) for g in df["group"].unique()})}
    for grp in sorted(df["group"].unique()):
        if cfg.dim >= 1:
            figures[f"failure_region_cell{grp}.png"] = fig_pairwise(done[done["group"] == grp], cfg,
                                                                  title=_group_label(plan, grp))
    params = "; ".join(f"`{p.key}` in [{p.low:g}, {p.high:g}], nominal {p.nominal}"
                       + (f" (mean {p.mean:g}, sd {p.sd:g})" if p.nominal == "normal" else "") for p in cfg.params)
    lines = [
        f"# Failure search: {plan.study.name}",
        "",
        plan.study.description,
        "",
        f"- searched: {params}",
        f"- methods: {', '.join(cfg.methods)}; falsifier `{cfg.sampler}`; batch {cfg.batch_size}; "
        f"{len(done)} of {len(df)} proposed trials finished",
        f"- terrain and mission: {'fixed' if cfg.fix_terrain else 'random'} terrain, "
        f"{'fixed' if cfg.fix_mission else 'random'} mission (study seeds, root {plan.study.root_seed})"
        + ((f"; the falsifier's local search (step {cfg.local_step:g} of a range) re-drives the terrains of its "
            f"failures, {cfg.explore_slots} of every {cfg.batch_size} proposals on fresh terrains"
            if cfg.local_terrain == "same" else
            f"; the falsifier's local search moves its failures by {cfg.local_step:g} of a range, "
            f"{cfg.batch_size - cfg.explore_slots} of every {cfg.batch_size} proposals"
            + ("" if cfg.fix_terrain else ", every proposal on a fresh terrain"))
           if cfg.local_step else ""),
        f"- distinct failures: at least {cfg.distinct_distance:g} of a range apart in some parameter "
        "(`terrains failed`: how many different terrains the failures lie on)",
        f"- code: {provenance(meta)}",
        "",
        *_plan_lines(plan),
        *analysis_lines,
        "## Failures found against trials spent",
        "",
        markdown_table(summary),
        "",
        "![failures vs trials](failures_vs_trials.png)",
        "",
        "## P(failure) under the nominal distribution",
        "",
        ("Plain Monte Carlo from the `random` stream (Clopper-Pearson interval); cross-entropy importance "
         "sampling from the `ce-is` stream (its adaptive stages counted in `trials`; normal interval of the "
         "defensive-mixture estimate). `trials for 10 % rel. error` extrapolates each estimator's variance; "
         "`MC trials for this rel. error / trials`: plain Monte Carlo's trials for the estimator's relative error "
         "at the Monte Carlo estimate, over the trials the estimator spent (it takes Monte Carlo's p with the "
         "estimator's relative error about its own p: the standard gain at one common p is in the section on the "
         "reference above); `covers MC`: whether its interval holds "
         "the Monte Carlo estimate."),
        "",
        markdown_table(est_table) if len(est_table) else "(no `random` or `ce-is` trials)",
        "",
        *([("What importance sampling over the searched parameters can gain at best, from the Monte Carlo "
            "stream: P (1 - P) / ((E sqrt p)^2 - P^2) with p(theta) = P(fail | theta) taken as the failure rate "
            "in bins of one parameter (standard-normal edges -2, -1.5, -1, 0, 1, 1.5, 2; "
            "offroadbench.search.estimators.best_is_gain). Near 1: the failures are not in the parameters "
            "(the terrain or mission drawn carries them) and plain Monte Carlo is the estimator; large: "
            "importance sampling can pay. Sparse bins make it noisy."),
           "", markdown_table(bounds), ""] if len(bounds) else []),
        "## The failure region",
        "",
        *[f"![failure region, cell {g}](failure_region_cell{g}.png)" for g in sorted(df["group"].unique())],
        "",
        "## Worst failures (lowest margin), to replay",
        "",
    ]
    for _, r in worst.iterrows():
        vals = ", ".join(f"{k} = {r[k]:.4g}" for k in cfg.keys)
        lines += [f"- cell {r['cell']} ({r['method']}, {r['failure_reason']}, margin {r['margin']:.3f}; {vals}): "
                  f"`offroadbench study replay {run_dir} --cell {r['cell']} --terrain 0 --mission 0 --plot "
                  f"--animate cell{r['cell']}.gif`"]
    if worst.empty:
        lines.append("(no failure found)")
    lines.append("")
    tables = {"trials.csv": df, "streams.csv": summary, "estimates.csv": est_table, "is_gain_bounds.csv": bounds,
              **analysis_tables}
    return Report(markdown="\n".join(lines), figures=figures, tables=tables)


def search_report_html(run_dir: str | Path, report) -> str:
    """The report as one self-contained HTML page (offroadbench.study.report.html.build_html): the
    Markdown with its figures inline, then one sortable row per search trial (its stream, stage,
    parameters, margin and outcome; a failure's row gives its replay command or links to a replay
    found in the run directory)."""
    from offroadbench.study.report.html import build_html, figure_png, find_replays

    run_dir = Path(run_dir)
    df, plan = search_table(run_dir)
    trials = df[df["done"]].assign(terrain=0, mission=0, success=lambda d: ~d["failed"].astype(bool))
    columns = ["group", "method", "stage", *plan.search.keys, "margin", "log_w"]
    figures = {name: figure_png(fig) for name, fig in report.figures.items()}
    return build_html(f"Search report: {plan.study.name}", report.markdown, figures, trials,
                      find_replays([run_dir / "replays", run_dir]), str(run_dir), grid_columns=columns)
