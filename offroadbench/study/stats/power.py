"""Power of a study's planned tests before the run, simulated from a committed pilot.

A plan (``[analysis]``, offroadbench.study.stats.plan) that names a ``pilot`` (a trial table of an earlier
run: Parquet or CSV with the study's grid columns, ``terrain``, ``success`` and the metrics; or a
per-terrain count table with ``successes`` and ``missions``) gets, for every expanded test, its power at
the effect it is meant to detect (the comparison's ``effect``, in the metric's unit, treatment - control):

1. The pilot's per-terrain differences of the test (the same cells, metric and per-terrain summary as the
   test itself; a stratum value the pilot lacks is read at the comparison's ``pilot_where`` value) are
   centred on the stated effect, d_j - mean(d) + effect: the pilot supplies the spread and shape of the
   per-terrain differences (ties, skew, terrains where nothing moves), the plan the effect.
2. Each simulated study draws, for every test of the plan, its number of terrains with replacement from
   those differences (the terrains of one draw are shared by all tests whose pilots share terrains, so
   their dependence is kept), computes the test the plan will compute (the exact sign-flip test of the
   mean, Fisher 1935, as offroadbench.study.stats.clustered.sign_flip_test; or the Wilcoxon signed-rank
   test), and applies the plan's multiplicity rule over all of them (Holm 1979 step-down, or
   Bonferroni) at the plan's alpha. A test's power is the share of simulated studies in which it is
   rejected, so each test faces the Holm step it will face in the run, not only the strictest one.

With up to ``exact_max`` terrains the sign-flip p enumerates all 2^K sign patterns; beyond, it uses the
same ``n_flips`` random patterns (the identity among them) for every simulated study, a Monte Carlo p
whose standard error at p = 0.01 is about 0.0016 with 4000 patterns. The simulation is seeded (the
plan's ``seed`` and the test's key), so a plan's power is a fixed number. Pilot-selected effects tend
to be optimistic; the plan states the effect to detect, so the power is at that effect, not at the
pilot's mean. Efron & Tibshirani (1993, Ch. 6) for resampling the pilot's terrains.

:func:`check_power` is what ``study run`` calls: it refuses (one line, exit 2) a plan whose test is
under ``min_power`` unless that comparison is marked ``exploratory``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from offroadbench.errors import InputError

__all__ = ["family_power", "sign_flip_pvalues", "load_pilot", "pilot_terrain_values", "plan_power",
           "power_column", "check_power", "resolve_pilot"]


def sign_flip_pvalues(x: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Two-sided sign-flip p of each row of ``x`` (simulated studies x terrains) over the sign patterns
    ``signs`` (patterns x terrains): the share of patterns whose |sum| reaches the observed |sum|."""
    obs = np.abs(x.sum(axis=1))
    out = np.empty(x.shape[0])
    step = max(1, 2_000_000 // max(1, signs.shape[0]))
    for i in range(0, x.shape[0], step):
        sums = np.abs(x[i:i + step] @ signs.T)
        out[i:i + step] = np.mean(sums >= obs[i:i + step, None] * (1 - 1e-12) - 1e-300, axis=1)
    return out


def _signs(k: int, rng: np.random.Generator, exact_max: int, n_flips: int) -> np.ndarray:
    if k <= exact_max:
        return (1 - 2 * ((np.arange(2 ** k)[:, None] >> np.arange(k)) & 1)).astype(float)
    s = rng.choice([-1.0, 1.0], size=(n_flips, k))
    s[0] = 1.0
    return s


def adjust_rows(p: np.ndarray, multiplicity: str) -> np.ndarray:
    """Holm or Bonferroni adjustment of each row of ``p`` (simulated studies x tests)."""
    m = p.shape[1]
    if multiplicity == "bonferroni":
        return np.minimum(1.0, p * m)
    order = np.argsort(p, axis=1, kind="stable")
    ranked = np.take_along_axis(p, order, axis=1) * (m - np.arange(m))
    adj = np.minimum(1.0, np.maximum.accumulate(ranked, axis=1))
    out = np.empty_like(p)
    np.put_along_axis(out, order, adj, axis=1)
    return out


def family_power(pilots: Sequence[np.ndarray], n_terrains: Sequence[int], alpha: float,
                 rng: np.random.Generator, *, effects: Sequence[float | None] | None = None,
                 multiplicity: str = "holm", tests: Sequence[str] | None = None, groups: Sequence[Any] | None = None,
                 n_sim: int = 1000, exact_max: int = 12, n_flips: int = 4000) -> np.ndarray:
    """Power of each of a family of paired tests under the family's multiplicity rule, by simulation.

    ``pilots[i]``: test i's per-terrain differences in the pilot (its truth up to a shift); ``effects[i]``:
    the mean to centre them on (None: the pilot's own mean); ``n_terrains[i]``: terrains of the planned
    test; ``tests[i]``: ``sign_flip`` (default) or ``wilcoxon``; ``groups[i]``: tests of one group whose
    pilots have the same length draw the same terrain indices (the pilots' terrains are the same ones).
    Returns the share of ``n_sim`` simulated studies in which each test's adjusted p is below ``alpha``
    (as offroadbench.study.stats.plan.confirmatory_table rejects)."""
    m = len(pilots)
    effects = list(effects) if effects is not None else [None] * m
    tests = list(tests) if tests is not None else ["sign_flip"] * m
    groups = list(groups) if groups is not None else list(range(m))
    truth = []
    for d, e in zip(pilots, effects, strict=True):
        d = np.asarray(d, float)
        d = d[np.isfinite(d)]
        if d.size == 0:
            raise InputError("power: a planned test has no per-terrain difference in its pilot")
        truth.append(d if e is None else d - d.mean() + float(e))
    p = np.ones((n_sim, m))
    draws: dict[tuple, np.ndarray] = {}
    for i in range(m):
        k, d = int(n_terrains[i]), truth[i]
        key = (groups[i], d.size, k)
        if key not in draws:
            draws[key] = rng.integers(0, d.size, size=(n_sim, k))
        x = d[draws[key]]
        if tests[i] == "wilcoxon":
            from offroadbench.study.stats.clustered import wilcoxon_test

            p[:, i] = [wilcoxon_test(row) for row in x]
        else:
            p[:, i] = sign_flip_pvalues(x, _signs(k, rng, exact_max, n_flips))
    return np.mean(adjust_rows(p, multiplicity) < alpha, axis=0)


# ---------------------------------------------------------------------------- pilots
def resolve_pilot(name: str, base_dirs: Sequence[str | Path | None] = ()) -> Path | None:
    """The pilot file ``name``: absolute, or relative to the first of ``base_dirs`` (the study TOML's
    folder first), the working directory or its ``experiments/`` folder that holds it; None if none does."""
    p = Path(name)
    if p.is_absolute():
        return p if p.is_file() else None
    for base in [*base_dirs, Path.cwd(), Path.cwd() / "experiments"]:
        if base is not None and (Path(base) / p).is_file():
            return Path(base) / p
    return None


def load_pilot(path: str | Path) -> pd.DataFrame:
    """A pilot table (Parquet or CSV)."""
    path = Path(path)
    try:
        return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"pilot {path}: cannot read it ({exc})") from None


def _select(pilot: pd.DataFrame, values: Mapping[str, Any]) -> pd.DataFrame:
    t = pilot
    for col, v in values.items():
        if col not in t:
            continue
        t = t[np.isclose(t[col].astype(float), float(v))] if isinstance(v, (int, float)) and not isinstance(
            v, bool) and pd.api.types.is_numeric_dtype(t[col]) and not pd.api.types.is_bool_dtype(t[col]) else t[
            t[col] == v]
    return t


def pilot_terrain_values(rows: pd.DataFrame, metric: str, summary: str = "median",
                         pool: Sequence[str] = ()) -> pd.Series:
    """Per terrain: the metric's value in ``rows`` (one cell of a pilot), as the plan computes it
    (offroadbench.study.stats.plan.terrain_metric), averaged over the ``pool`` columns' values."""
    from offroadbench.study.stats.terrain import METRICS

    keys = ["terrain", *[c for c in pool if c in rows]]
    if metric == "success_rate_pct":
        if "success" in rows:
            v = rows.groupby(keys)["success"].mean().mul(100.0)
        else:
            g = rows.groupby(keys)[["successes", "missions"]].sum()
            v = 100.0 * g["successes"] / g["missions"]
    elif metric.startswith("area_"):
        v = rows.groupby(keys)[metric[:-4]].first().mul(100.0)
    else:
        part = rows[rows["success"].astype(bool)] if metric in METRICS else rows
        v = part.groupby(keys)[metric].agg(summary)
    return v.groupby(level="terrain").mean() if len(keys) > 1 else v


def within_design(pilot: pd.DataFrame, cells: Sequence[Mapping[str, Any]], columns: Mapping[str, str],
                   keep: Sequence[str] = ()) -> pd.DataFrame:
    """The pilot's rows whose grid columns take values of the study's axes (a pooled axis pools the study's
    values only: a vehicle the study drops is dropped from its pilot too), except the axes in ``keep``."""
    t = pilot
    for key in {k for c in cells for k in c}:
        col = columns.get(key, key)
        if key in keep or col not in t:
            continue
        values = {c[key] for c in cells}
        num = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if num and len(num) == len(values) and pd.api.types.is_numeric_dtype(t[col]) and not pd.api.types.is_bool_dtype(t[col]):
            t = t[np.isclose(t[col].to_numpy(float)[:, None], np.array(num, float)[None, :]).any(axis=1)]
        else:
            t = t[t[col].isin(values)]
    return t


def _pilot_differences(pilot: pd.DataFrame, comp: Any, stratum: Mapping[str, Any], columns: Mapping[str, str],
                       cells: Sequence[Mapping[str, Any]] = ()) -> np.ndarray:
    pilot = within_design(pilot, cells, columns, keep=list(comp.pilot_where)) if cells else pilot
    strat = {**stratum, **{k: v for k, v in comp.pilot_where.items()}}
    base = {columns.get(k, k): v for k, v in strat.items()}
    t = _select(pilot, {**base, **{columns.get(k, k): v for k, v in comp.treatment.items()}})
    c = _select(pilot, {**base, **{columns.get(k, k): v for k, v in comp.control.items()}})
    pool = [columns.get(k, k) for k in comp.pool]
    a = pilot_terrain_values(t, comp.metric, comp.summary, pool)
    b = pilot_terrain_values(c, comp.metric, comp.summary, pool)
    d = (a - b.reindex(a.index)).dropna().to_numpy(float)
    if d.size == 0:
        raise InputError(f"analysis comparison {comp.name!r} ({', '.join(f'{k} = {v}' for k, v in base.items())}): "
                         "its pilot has no terrain with both cells; set pilot_where to the pilot's values")
    return d


def plan_power(plan: Any, cells: Sequence[Mapping[str, Any]], columns: Mapping[str, str], n_terrains: int,
               pilot: pd.DataFrame) -> pd.DataFrame:
    """Power of every expanded test of ``plan`` with ``n_terrains`` terrains per cell, from ``pilot``.

    One row per test, in confirmatory_table's order: comparison, stratum, exploratory, effect (the
    plan's), pilot_terrains, pilot_mean, pilot_sd (of the pilot's per-terrain differences), terrains, power.
    """
    from offroadbench.study.stats.clustered import keyed_rng
    from offroadbench.study.stats.plan import cell_label, expand

    for col, v in plan.pilot_select.items():
        if col not in pilot:
            raise InputError(f"analysis.pilot_select: the pilot has no column {col!r}")
        pilot = _select(pilot, {col: v})
    rows, diffs, effects, tests, groups = [], [], [], [], []
    for comp, stratum, _, _ in expand(plan, cells):
        if comp.test == "permutation":
            raise InputError(f"analysis comparison {comp.name!r}: power is simulated for paired tests only")
        d = _pilot_differences(pilot, comp, stratum, columns, cells)
        diffs.append(d)
        effects.append(comp.effect)
        tests.append(comp.test)
        groups.append("pilot")
        rows.append({"comparison": comp.name, "stratum": cell_label(stratum, columns), "exploratory": comp.exploratory,
                     "effect": comp.effect if comp.effect is not None else math.nan, "pilot_terrains": int(d.size),
                     "pilot_mean": float(d.mean()), "pilot_sd": float(d.std(ddof=1)) if d.size > 1 else math.nan,
                     "terrains": int(n_terrains)})
    out = pd.DataFrame(rows)
    if rows:
        rng = keyed_rng(plan.seed, "power", n_terrains, plan.power_sims)
        out["power"] = family_power(diffs, [n_terrains] * len(diffs), plan.alpha, rng, effects=effects,
                                    multiplicity=plan.multiplicity, tests=tests, groups=groups, n_sim=plan.power_sims)
    return out


def _study_power(study: Any, base_dirs: Sequence[str | Path | None]) -> pd.DataFrame | None:
    plan = study.analysis
    if plan is None or not plan.pilot:
        return None
    path = resolve_pilot(plan.pilot, base_dirs)
    if path is None:
        raise InputError(f"[analysis] pilot = {plan.pilot!r}: no such file (relative to the study TOML's folder, "
                         "the working directory or its experiments/ folder)")
    return plan_power(plan, study.cell_values(), study.column_names(), study.terrains_per_cell, load_pilot(path))


def power_column(meta: Mapping[str, Any], base_dirs: Sequence[str | Path | None] = ()) -> pd.DataFrame | None:
    """The power of a stored plan's tests (as :func:`plan_power`), or None when the plan names no pilot or
    its pilot is not found here."""
    from offroadbench.study.stats.plan import stored_plan

    plan = stored_plan(meta)
    if plan is None or not plan.pilot:
        return None
    path = resolve_pilot(plan.pilot, base_dirs)
    if path is None:
        return None
    cells = [c["values"] for c in sorted(meta["cells"], key=lambda c: c["index"])]
    return plan_power(plan, cells, meta.get("columns", {}), int(meta["study"]["terrains_per_cell"]), load_pilot(path))


def check_power(study: Any, base_dir: str | Path | None = None) -> pd.DataFrame | None:
    """Refuse (one InputError) a study whose planned, non-exploratory test has power under the plan's
    ``min_power`` at its stated effect; returns the power table (None: the plan names no pilot)."""
    table = _study_power(study, [base_dir])
    if table is None:
        return None
    low = table[(~table["exploratory"]) & (table["power"] < study.analysis.min_power)]
    if len(low):
        r = low.iloc[0]
        raise InputError(f"study {study.name!r}: planned test {r['comparison']!r} ({r['stratum']}) has power "
                         f"{r['power']:.2f} < {study.analysis.min_power:g} at effect {r['effect']:g} with "
                         f"{r['terrains']} terrains (pilot {study.analysis.pilot}; {len(low)} test(s) under it): "
                         "add terrains, or mark the comparison exploratory = true")
    return table
