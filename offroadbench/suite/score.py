"""A suite run's score card as plain data (``score.json``): tasks, terrains, categories, aggregate.

Every number of the card is computed here from the card's own task rows (:func:`summarise`), so
a committed card can be checked against its rows (tests/suite). A task is one mission of one
terrain of one category; a task with no trial row (a fault: a planner that refused, a trial past
its time limit) counts as a failure, reason ``fault``, score 0.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from offroadbench.suite import stats
from offroadbench.suite.spec import SuiteConfig

__all__ = ["CARD_FORMAT", "PROFILE_TAUS", "TASK_KEYS", "compare", "make_card", "summarise", "task_rows"]

#: the score card's format tag (bumped when its fields change meaning)
CARD_FORMAT = "offroadbench-score-card/1"
#: a task's identity within a suite tier (with its seeds, checked when two cards are paired)
TASK_KEYS = ("category", "cell", "terrain", "mission")
#: the performance profile's thresholds tau on the task score
PROFILE_TAUS = tuple(round(0.01 * i, 2) for i in range(101))
#: metrics of the task rows kept in the card (seconds, m/s^2)
_KEPT = ("traversal_time_s", "rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s")


def _level(values: Mapping[str, Any]) -> str:
    """A cell's grid values in words, e.g. ``D_high 2.3`` (empty for a category without a grid)."""
    return ", ".join(f"{k.rsplit('.', 1)[-1]} {v}" for k, v in values.items())


def task_rows(suite: SuiteConfig, category: str, run_dir: str | Path) -> list[dict[str, Any]]:
    """One row per task of a category's run directory: every (cell, terrain, mission) of its study,
    with the trial's outcome and metrics, its nominal time and its BARN score."""
    from offroadbench.study import load, load_meta

    meta = load_meta(run_dir)
    trials = load(run_dir)
    by_key = {(int(r.cell), int(r.terrain), int(r.mission)): r for r in trials.itertuples(index=False)} if len(trials) else {}
    lo, hi = suite.time_clip_factors
    rows = []
    for info in meta["cells"]:
        cell = int(info["index"])
        for terrain in range(int(meta["study"]["terrains_per_cell"])):
            for mission in range(int(meta["study"]["missions_per_terrain"])):
                r = by_key.get((cell, terrain, mission))
                row: dict[str, Any] = {"category": category, "cell": cell, "level": _level(info["values"]),
                                       "terrain": terrain, "mission": mission}
                if r is None:
                    row.update(terrain_seed=None, mission_seed=None, success=False, failure_reason="fault",
                               nominal_time_s=None, score=0.0, **{k: None for k in _KEPT})
                else:
                    nominal = math.hypot(r.goal_x_m - r.start_x_m, r.goal_y_m - r.start_y_m) / suite.nominal_speed_m_s
                    row.update(terrain_seed=int(r.terrain_seed), mission_seed=int(r.mission_seed), success=bool(r.success),
                               failure_reason=str(r.failure_reason or ""), nominal_time_s=round(nominal, 6),
                               score=round(stats.barn_score(bool(r.success), float(r.traversal_time_s), nominal, lo, hi), 6),
                               **{k: _num(getattr(r, k)) for k in _KEPT})
                rows.append(row)
    return rows


def _num(v: Any) -> float | None:
    """A finite float rounded for the card, or None (JSON has no NaN)."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return round(x, 6) if math.isfinite(x) else None


def terrain_table(tasks: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """One row per terrain (category, cell, terrain): success %, mean score, and the mean time and
    ride of its successful tasks (NaN when none succeeded)."""
    df = pd.DataFrame(list(tasks))
    ok = df["success"].astype(bool)
    for k in ("traversal_time_s", "rms_vertical_accel_m_s2"):
        df[k + "_ok"] = pd.to_numeric(df[k], errors="coerce").where(ok)
    g = df.groupby(["category", "cell", "terrain"], sort=False)
    return pd.DataFrame({
        "success_pct": g["success"].mean() * 100.0,
        "score": g["score"].mean(),
        "time_s": g["traversal_time_s_ok"].mean(),
        "ride_m_s2": g["rms_vertical_accel_m_s2_ok"].mean(),
        "tasks": g.size(),
    }).reset_index()


def _value_ci(values, seed: int) -> dict[str, Any]:
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    lo, hi = stats.mean_interval(x, seed=seed)
    return {"mean": _num(x.mean()) if x.size else None, "ci": [_num(lo), _num(hi)], "terrains": int(x.size)}


def summarise(tasks: Sequence[Mapping[str, Any]], categories: Sequence[str]) -> dict[str, Any]:
    """The card's summary from its task rows: per category (success, time, ride, score, each as the
    mean over terrains with its terrain-level interval; failure modes counted over tasks) and overall
    (IQM of per-terrain scores with its stratified bootstrap interval, the performance profile)."""
    terr = terrain_table(tasks)
    df = pd.DataFrame(list(tasks))
    out_cats = []
    for i, name in enumerate(categories):
        t = terr[terr["category"] == name]
        reasons = df.loc[(df["category"] == name) & ~df["success"].astype(bool), "failure_reason"].value_counts()
        out_cats.append({
            "name": name, "terrains": int(len(t)), "tasks": int(t["tasks"].sum()),
            "successes": int(df.loc[df["category"] == name, "success"].astype(bool).sum()),
            "success_pct": _value_ci(t["success_pct"], seed=10 * i + 1),
            "time_s": _value_ci(t["time_s"], seed=10 * i + 2),
            "ride_m_s2": _value_ci(t["ride_m_s2"], seed=10 * i + 3),
            "score": _value_ci(t["score"], seed=10 * i + 4),
            "score_iqm": _num(stats.iqm(t["score"])),
            "failures": {str(k): int(v) for k, v in sorted(reasons.items())},
        })
    strata = [terr.loc[terr["category"] == c, "score"].to_numpy() for c in categories]
    lo, hi = stats.stratified_interval(strata, stats.iqm, seed=7)
    slo, shi = stats.stratified_interval([terr.loc[terr["category"] == c, "success_pct"].to_numpy() for c in categories],
                                         np.mean, seed=8)
    overall = {
        "terrains": int(len(terr)), "tasks": int(len(df)), "successes": int(df["success"].astype(bool).sum()),
        "faults": int((df["failure_reason"] == "fault").sum()),
        "score_iqm": _num(stats.iqm(terr["score"])), "score_iqm_ci": [_num(lo), _num(hi)],
        "score_mean": _num(terr["score"].mean()),
        "success_pct": _num(terr["success_pct"].mean()), "success_pct_ci": [_num(slo), _num(shi)],
    }
    profile = {"taus": list(PROFILE_TAUS), "fraction": stats.performance_profile(terr["score"], PROFILE_TAUS)}
    return {"overall": overall, "categories": out_cats, "profile": profile}


def make_card(suite: SuiteConfig, suite_file: str, tier: str, planner: str, tasks: list[dict[str, Any]],
              run: Mapping[str, Any]) -> dict[str, Any]:
    """The score card (``score.json``): the suite's version, the planner, what ran, the summary and
    every task row. ``run``: code version, dates, trials run and wall time (information only)."""
    categories = [c.name for c in suite.categories]
    return {
        "format": CARD_FORMAT,
        "suite": {"name": suite.name, "tasks_sha256": suite.tasks_sha256, "tier": tier,
                  "tier_description": suite.tier(tier).description, "description": suite.description,
                  "vehicle": suite.vehicle, "sensor": suite.sensor, "nominal_speed_m_s": suite.nominal_speed_m_s,
                  "time_clip_factors": list(suite.time_clip_factors), "file": suite_file,
                  "categories": {c.name: c.description for c in suite.categories}},
        "planner": planner,
        "command": f"offroadbench suite run --suite {suite.name} --tier {tier} --planner {planner}",
        "run": dict(run),
        **summarise(tasks, categories),
        "tasks": tasks,
    }


def _terrain_scores(card: Mapping[str, Any]) -> pd.DataFrame:
    return terrain_table(card["tasks"]).set_index(["category", "cell", "terrain"])


def compare(card: Mapping[str, Any], base: Mapping[str, Any]) -> dict[str, Any]:
    """Paired comparison of ``card`` against a baseline card on the same tasks: per-terrain score and
    success differences (this - baseline), their means with stratified bootstrap intervals, the
    sign-flip p over terrains, and the tasks won, tied and lost. ``comparable`` is False (with the
    reason) when the cards are not of the same suite, tasks and tier."""
    head = {"baseline": base["planner"], "comparable": False}
    for key in ("name", "tasks_sha256", "tier"):
        if card["suite"][key] != base["suite"][key]:
            return {**head, "reason": f"suite {key} differs ({card['suite'][key]} vs {base['suite'][key]})"}
    mine = {tuple(t[k] for k in TASK_KEYS): t for t in card["tasks"]}
    theirs = {tuple(t[k] for k in TASK_KEYS): t for t in base["tasks"]}
    if set(mine) != set(theirs):
        return {**head, "reason": "the cards hold different tasks"}
    for key, t in mine.items():
        b = theirs[key]
        if None not in (t["terrain_seed"], b["terrain_seed"]) and (t["terrain_seed"], t["mission_seed"]) != (b["terrain_seed"], b["mission_seed"]):
            return {**head, "reason": f"task {key} has other seeds"}
    a, b = _terrain_scores(card), _terrain_scores(base)
    cats = list(card["suite"]["categories"])
    d_score = (a["score"] - b["score"]).reset_index()
    d_success = (a["success_pct"] - b["success_pct"]).reset_index()
    strata = [d_score.loc[d_score["category"] == c, "score"].to_numpy() for c in cats]
    lo, hi = stats.stratified_interval(strata, np.mean, seed=11)
    slo, shi = stats.stratified_interval([d_success.loc[d_success["category"] == c, "success_pct"].to_numpy() for c in cats],
                                         np.mean, seed=12)
    diff = np.array([mine[k]["score"] - theirs[k]["score"] for k in mine])
    return {**head, "comparable": True, "terrains": int(len(d_score)),
            "score_diff": _num(d_score["score"].mean()), "score_diff_ci": [_num(lo), _num(hi)],
            "success_diff_pts": _num(d_success["success_pct"].mean()), "success_diff_ci": [_num(slo), _num(shi)],
            "p_sign_flip": _num(stats.sign_flip_p(d_score["score"].to_numpy(), seed=13)),
            "tasks_won": int((diff > 1e-9).sum()), "tasks_tied": int((np.abs(diff) <= 1e-9).sum()),
            "tasks_lost": int((diff < -1e-9).sum()),
            "baseline_score_iqm": base["overall"]["score_iqm"], "baseline_success_pct": base["overall"]["success_pct"]}
