"""The paper's statistics (Majhor & Bos 2023, Sec. 2.4, 3): medians, IQR (Eq. 6), 1.5 IQR outliers
(Eq. 7-8), per-terrain success rate (Eq. 5), and the group tables of a study; and, beyond the
paper, :func:`terrain_changes`: each change between consecutive groups tested with the terrain as
the unit (offroadbench.study.stats.clustered).

Quartiles use the ``hazen`` definition (the p-th percentile sits at rank n p / 100 + 1/2),
which is MATLAB's ``prctile``, the tool the paper's box plots come from (red medians, red "+"
outliers, whiskers to the furthest point inside the fences). The figures are drawn from these
same numbers (``Axes.bxp``), so tables and plots agree exactly.
"""

from __future__ import annotations

import itertools
import math
from typing import Any, Sequence

import numpy as np
import pandas as pd

from offroadbench.study.stats.metrics import CLASSES, METRICS, SOIL_METRICS

__all__ = [
    "QUANTILE_METHOD",
    "WHISKER_IQR",
    "METRICS",
    "SOIL_METRICS",
    "soil_boxes",
    "CLASSES",
    "box_stats",
    "terrain_success",
    "group_summary",
    "failure_table",
    "median_changes",
    "median_change_intervals",
    "group_labels",
    "success_boxes",
    "metric_boxes",
    "terrain_values",
    "terrain_changes",
]

QUANTILE_METHOD = "hazen"
#: whisker reach in IQRs: points beyond Q3 + 1.5 IQR or below Q1 - 1.5 IQR are outliers (Eq. 7-8)
WHISKER_IQR = 1.5

def box_stats(values: Sequence[float], whis: float = WHISKER_IQR) -> dict[str, Any]:
    """Median, quartiles, IQR (Eq. 6), fences (Eq. 7-8), whisker ends and outliers of ``values``.

    NaNs are ignored. An empty input gives n = 0 and NaN statistics. ``values``: the samples, sorted
    (box plots of few samples show them).
    """
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        nan = float("nan")
        return dict(n=0, median=nan, q1=nan, q3=nan, iqr=nan, lower_fence=nan, upper_fence=nan,
                    whislo=nan, whishi=nan, fliers=np.array([]), n_outliers=0, values=x)
    q1, med, q3 = np.percentile(x, [25, 50, 75], method=QUANTILE_METHOD)
    iqr = q3 - q1
    lo, hi = q1 - whis * iqr, q3 + whis * iqr
    inside = x[(x >= lo) & (x <= hi)]
    fliers = x[(x < lo) | (x > hi)]
    return dict(n=int(x.size), median=float(med), q1=float(q1), q3=float(q3), iqr=float(iqr),
                lower_fence=float(lo), upper_fence=float(hi), whislo=float(inside.min()),
                whishi=float(inside.max()), fliers=fliers, n_outliers=int(fliers.size), values=np.sort(x))


def group_labels(meta: dict[str, Any]) -> dict[int, str]:
    """Short label of each cell from its grid values, e.g. ``D_high = 2.3``."""
    columns = meta["columns"]
    out = {}
    for c in meta["cells"]:
        parts = [f"{columns[k]} = {v}" for k, v in c["values"].items()]
        out[c["index"]] = ", ".join(parts) or "all"
    return out


def terrain_success(trials: pd.DataFrame) -> pd.DataFrame:
    """Per terrain: trials, successes and success rate in percent (Eq. 5)."""
    g = trials.groupby(["cell", "terrain"], sort=True)["success"]
    out = pd.DataFrame({"trials": g.size(), "successes": g.sum().astype(int)}).reset_index()
    out["success_rate_pct"] = 100.0 * out["successes"] / out["trials"]
    return out


def success_boxes(per_terrain: pd.DataFrame, labels: dict[int, str]) -> dict[str, dict[str, Any]]:
    """Fig. 6: group label -> :func:`box_stats` of its per-terrain success rates (%), in cell order."""
    return {labels[c]: box_stats(per_terrain.loc[per_terrain["cell"] == c, "success_rate_pct"]) for c in sorted(labels)}


def metric_boxes(trials: pd.DataFrame, labels: dict[int, str]) -> dict[str, dict[str, dict[str, Any]]]:
    """Fig. 7: metric column -> group label -> :func:`box_stats` over the group's successful trials."""
    ok = trials[trials["success"].astype(bool)]
    return {metric: {labels[c]: box_stats(ok.loc[ok["cell"] == c, metric]) for c in sorted(labels)} for metric in METRICS}


def soil_boxes(trials: pd.DataFrame, labels: dict[int, str]) -> dict[str, dict[str, dict[str, Any]]]:
    """:data:`SOIL_METRICS` -> group label -> :func:`box_stats` over every trial (successful or not)
    of the groups driven on soil (a finite ``mean_slip``); empty when no group was."""
    if "mean_slip" not in trials:
        return {}
    soil = sorted(c for c in labels if np.isfinite(trials.loc[trials["cell"] == c, "mean_slip"].astype(float)).any())
    return {m: {labels[c]: box_stats(trials.loc[trials["cell"] == c, m] if m in trials else ()) for c in soil}
            for m in SOIL_METRICS} if soil else {}


def group_summary(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str]) -> pd.DataFrame:
    """One row per grid cell: counts, per-terrain success rate, class areas and Fig. 7 metrics.

    Metrics are over successful trials only (Sec. 2.4). Columns ``<stat>_<name>`` with stat in
    median, q1, q3, iqr, n, outliers.
    """
    per_terrain = terrain_success(trials)
    rows = []
    for cell in sorted(labels):
        t = trials[trials["cell"] == cell]
        ok = t[t["success"].astype(bool)]
        row: dict[str, Any] = {"cell": cell, "group": labels[cell], "terrains": int(t["terrain"].nunique()),
                               "trials": int(len(t)), "successes": int(ok.shape[0])}
        series = {"success_rate_pct": per_terrain.loc[per_terrain["cell"] == cell, "success_rate_pct"]}
        ter = terrains[terrains["cell"] == cell]
        for cls in CLASSES:
            col = f"area_{cls}"
            if col in ter:
                series[f"{col}_pct"] = 100.0 * ter[col]
        for metric in METRICS:
            if metric in ok:
                series[metric] = ok[metric]
        for name, values in series.items():
            s = box_stats(values)
            for stat in ("median", "q1", "q3", "iqr", "n"):
                row[f"{stat}_{name}"] = s[stat]
            row[f"outliers_{name}"] = s["n_outliers"]
        rows.append(row)
    return pd.DataFrame(rows)


def failure_table(trials: pd.DataFrame, labels: dict[int, str]) -> pd.DataFrame:
    """Trials per cell and failure reason (``success`` for successful trials)."""
    reason = trials["failure_reason"].where(~trials["success"].astype(bool), "success").replace("", "unknown")
    table = pd.crosstab(trials["cell"].map(labels), reason).reindex([labels[c] for c in sorted(labels)], fill_value=0)
    table.index.name = "group"
    table.columns.name = None
    cols = ["success"] + sorted(c for c in table.columns if c != "success")
    return table.reindex(columns=[c for c in cols if c in table.columns])


def median_changes(summary: pd.DataFrame, names: Sequence[str]) -> pd.DataFrame:
    """Change of each group median from one cell to the next: absolute and percent of the first."""
    rows = []
    groups = list(summary["group"])
    for name in names:
        med = summary[f"median_{name}"].to_numpy(dtype=float)
        for i in range(len(med) - 1):
            change = med[i + 1] - med[i]
            pct = 100.0 * change / med[i] if med[i] != 0 else float("nan")
            rows.append({"quantity": name, "from": groups[i], "to": groups[i + 1], "median_from": med[i],
                         "median_to": med[i + 1], "change": change, "change_pct": pct})
    return pd.DataFrame(rows)


def median_change_intervals(trials: pd.DataFrame, terrains: pd.DataFrame, changes: pd.DataFrame,
                            labels: dict[int, str], seed: int = 0, n_boot: int = 1000,
                            level: float = 0.95) -> pd.DataFrame:
    """Terrain-cluster bootstrap intervals of each row of :func:`median_changes` (``ci95_low``,
    ``ci95_high``): the terrains are resampled (the same terrain indices in both groups: terrain j of
    every cell shares its seed), and the change of the group medians is recomputed from the resampled
    terrains' values (per-terrain success rates and class areas) or from all the successful trials
    of the resampled terrains (Fig. 7 metrics, as the medians themselves are)."""
    rng = np.random.default_rng(seed)
    cell_of = {g: c for c, g in labels.items()}
    per = terrain_values(trials, terrains, [n for n in changes["quantity"].unique() if not n in METRICS])
    ok = trials[trials["success"].astype(bool)]
    ids = sorted(trials["terrain"].unique())
    draws = rng.integers(0, len(ids), size=(n_boot, len(ids)))
    a = (1.0 - level) / 2.0
    lows, highs = [], []
    for r in changes.itertuples(index=False):
        c0, c1 = cell_of[r[1]], cell_of[r[2]]
        name = r[0]
        if name in METRICS:
            groups = [{t: g[name].dropna().to_numpy(float) for t, g in ok[ok["cell"] == c].groupby("terrain")}
                      for c in (c0, c1)]
            def med(g, d):
                parts = [g[ids[i]] for i in d if ids[i] in g]
                x = np.concatenate(parts) if parts else np.array([])
                return float(np.percentile(x, 50, method=QUANTILE_METHOD)) if x.size else math.nan
        else:
            groups = [per[per["cell"] == c].set_index("terrain")[name].to_dict() for c in (c0, c1)]
            def med(g, d):
                x = np.array([g[ids[i]] for i in d if ids[i] in g], float)
                x = x[np.isfinite(x)]
                return float(np.percentile(x, 50, method=QUANTILE_METHOD)) if x.size else math.nan
        stats = np.array([med(groups[1], d) - med(groups[0], d) for d in draws])
        stats = stats[np.isfinite(stats)]
        lo, hi = np.percentile(stats, [100 * a, 100 * (1 - a)], method="inverted_cdf") if stats.size else (math.nan,) * 2
        lows.append(float(lo))
        highs.append(float(hi))
    return changes.assign(ci95_low=lows, ci95_high=highs)


def terrain_values(trials: pd.DataFrame, terrains: pd.DataFrame, names: Sequence[str]) -> pd.DataFrame:
    """One row per (cell, terrain), one column per quantity: the per-terrain success rate (Eq. 5),
    class areas in % (``area_<class>_pct``), each Fig. 7 metric's median over the terrain's
    successful trials (NaN when it had none), and each soil metric's median over all its trials."""
    out = terrain_success(trials).set_index(["cell", "terrain"])[["success_rate_pct"]]
    ter = terrains.set_index(["cell", "terrain"])
    ok = trials[trials["success"].astype(bool)]
    for name in names:
        if name.startswith("area_") and name.endswith("_pct") and name[:-4] in ter:
            out[name] = 100.0 * ter[name[:-4]].reindex(out.index)
        elif name in METRICS and name in ok:
            out[name] = ok.groupby(["cell", "terrain"])[name].median().reindex(out.index)
        elif name in SOIL_METRICS and name in trials:  # every trial, failed ones included
            out[name] = trials.groupby(["cell", "terrain"])[name].median().reindex(out.index)
    return out.reset_index()


def terrain_changes(trials: pd.DataFrame, terrains: pd.DataFrame, labels: dict[int, str], names: Sequence[str],
                    paired: bool = True, seed: int = 0, n_boot: int = 2000,
                    pairs: Sequence[tuple[int, int]] | None = None) -> pd.DataFrame:
    """Each change between consecutive groups (or between the cells of ``pairs``, (from, to)), with
    the terrain as the unit.

    Paired terrains (terrain j of every cell from the same seed): per-terrain differences d_j (later
    minus earlier group), their mean with a terrain-bootstrap 95 % interval and its number of
    distinct resamples, the terrains that moved up / down, the Wilcoxon signed-rank p and the exact
    sign-flip p. Unpaired: the difference of the per-terrain means with an interval from resampling
    each group's terrains, and the Mann-Whitney U p (in ``p_wilcoxon``'s place; no sign-flip p).
    ``p_holm`` is Holm's adjustment of ``p_wilcoxon`` over every row; ``significant`` = p_holm < 0.05.
    Terrains without a value (no successful trial for a metric) are left out of that row.
    """
    from scipy.stats import mannwhitneyu

    from offroadbench.study.stats.clustered import (
        cluster_bootstrap,
        holm,
        sign_flip_test,
        wilcoxon_test,
    )

    rng = np.random.default_rng(seed)
    vals = terrain_values(trials, terrains, names)
    cells = sorted(labels)
    rows = []
    for name in names:
        if name not in vals:
            continue
        for c0, c1 in (pairs if pairs is not None else itertools.pairwise(cells)):
            a = vals[vals["cell"] == c0].set_index("terrain")[name]
            b = vals[vals["cell"] == c1].set_index("terrain")[name]
            row: dict[str, Any] = {"quantity": name, "from": labels[c0], "to": labels[c1]}
            if paired:
                d = (b - a.reindex(b.index)).dropna().to_numpy(float)
                boot = cluster_bootstrap(d, np.mean, rng, n_boot)
                row.update(terrains=d.size, mean_change=boot.estimate, ci95_low=boot.low, ci95_high=boot.high,
                           bootstrap_distinct=f"{boot.distinct} of {min(boot.possible, n_boot)}",
                           up=int((d > 0).sum()), down=int((d < 0).sum()),
                           p_wilcoxon=wilcoxon_test(d) if d.size else math.nan,
                           p_sign_flip=sign_flip_test(d, rng=rng) if d.size else math.nan)
            else:
                x, y = a.dropna().to_numpy(float), b.dropna().to_numpy(float)
                bx = cluster_bootstrap(x, np.mean, rng, n_boot)
                by = cluster_bootstrap(y, np.mean, rng, n_boot)
                diffs = (y[rng.integers(0, y.size, (n_boot, y.size))].mean(axis=1)
                         - x[rng.integers(0, x.size, (n_boot, x.size))].mean(axis=1)) if x.size and y.size else []
                lo, hi = np.percentile(diffs, [2.5, 97.5]) if len(diffs) else (math.nan, math.nan)
                p = float(mannwhitneyu(x, y).pvalue) if x.size and y.size else math.nan
                row.update(terrains=int(min(x.size, y.size)), mean_change=by.estimate - bx.estimate, ci95_low=lo,
                           ci95_high=hi, bootstrap_distinct="–", up=math.nan, down=math.nan, p_wilcoxon=p,
                           p_sign_flip=math.nan)
            rows.append(row)
    out = pd.DataFrame(rows)
    if not out.empty:
        out["p_holm"] = holm(out["p_wilcoxon"])
        out["significant"] = out["p_holm"] < 0.05
    return out
