"""The report of a search run directory: failures found against trials spent, the failure region,
P(failure) by importance sampling beside plain Monte Carlo, and the worst failures to replay.

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

__all__ = ["search_table", "stream_summary", "estimates", "first_failures", "build_search_report"]

#: how many distinct failures the "trials to the first k" column counts
FIRST_K = 10
#: worst failures listed with their replay commands
WORST = 5


def _plan_from_meta(meta: dict[str, Any]) -> SearchPlan:
    search_data = dict(meta["search"])
    search_data["params"] = [dict(p) for p in search_data["params"]]
    search = search_from_dict(search_data, where="stored [search]")
    head = ("name", "recipe", "root_seed", "description", "paired_terrains", "telemetry")
    study = study_from_dict({"study": {k: v for k, v in meta["study"].items() if k in head}})
    groups = tuple(CellPlan(index=g["index"], values=g["values"], key=g["seed_key"], recipe_data=g["recipe"],
                            settings=g["settings"]) for g in meta["groups"])
    return SearchPlan(search=search, study=study, groups=groups)


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


def build_search_report(run_dir: str | Path):
    """The report of a search run directory (offroadbench.study.report.markdown.Report)."""
    from offroadbench.search.figures import fig_failures_vs_trials, fig_pairwise
    from offroadbench.study.report.markdown import Report, markdown_table

    run_dir = Path(run_dir)
    df, plan = search_table(run_dir)
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
        "",
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
         "at the Monte Carlo estimate, over the trials the estimator spent; `covers MC`: whether its interval holds "
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
    tables = {"trials.csv": df, "streams.csv": summary, "estimates.csv": est_table, "is_gain_bounds.csv": bounds}
    return Report(markdown="\n".join(lines), figures=figures, tables=tables)
