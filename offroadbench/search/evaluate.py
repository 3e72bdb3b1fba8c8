"""The figures a search's analysis plan names, from a table of finished trials (the report's for one
run; a results folder's, run and repeats, for the committed figures).

* :func:`reference`: the reference P the estimates are judged at, obtained as the plan says
  (``boundary``: offroadbench.search.baselines.MeasuredBoundary over every finished trial of the
  group, whoever proposed it: an outcome at a parameter value is data; ``mc``: the ``random``
  stream's estimate).
* :func:`folder_reference`: the same, with the boundary measured on a committed results folder of
  the same site and route (``[analysis] reference_from``), integrated against this search's
  nominal, with a bootstrap interval over that folder's trials (:func:`reference_interval`); the
  run's own trials only check it (:func:`boundary_check`).
* :func:`is_summary`: the importance-sampling estimate with its normal and bootstrap-t intervals
  and the gain at the reference p (offroadbench.search.estimators.is_gain, from the run's stated
  standard error).
* :func:`mc_position`: where plain Monte Carlo's estimate sits against the reference, and why: its
  distance in its own standard errors, and (with a boundary) how many of its draws fell where
  failure is certain against how many the nominal puts there (a chance excess or shortage of such
  draws moves the estimate by exactly that count over n).
* :func:`falsifier_counts`: the falsifier's trials to the k-th failure against its baselines
  (offroadbench.search.baselines): the run's ``uniform`` and ``random`` streams where it has them
  (pool orders of real trials), else streams computed from the measured boundary.
* :func:`modes`: sensitivity, failure modes and each stream's modes and first failure
  (offroadbench.search.modes).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from offroadbench.errors import InputError
from offroadbench.search.analysis import SearchAnalysis
from offroadbench.search.baselines import (MeasuredBoundary, measured_boundary, median_interval, model_streams,
                                           nominal_draws, pool_streams, ratio_interval, trials_to_k, uniform_box)
from offroadbench.search.estimators import Estimate, bootstrap_t_interval, is_estimate, is_gain, mc_estimate
from offroadbench.search.modes import Sensitivity, failure_modes, mode_table, sensitivity, stream_modes
from offroadbench.search.space import SearchConfig, SearchParam

__all__ = ["Reference", "reference", "group_planner", "folder_trials", "folder_reference", "reference_interval",
           "boundary_check", "is_summary", "mc_position", "falsifier_counts", "modes", "stream_mode_rows",
           "repeat_streams", "pooled_reference", "is_repeats", "spread_gain", "stream_counts", "results_figures",
           "STREAMS", "SEED"]

#: streams of each computed or pool-order baseline
STREAMS = 2000
#: seed of every resampling here (bootstrap, permutations, computed streams): the figures are deterministic
SEED = 0


@dataclass(frozen=True)
class Reference:
    """The reference P of one group and how it was obtained."""

    p: float
    low: float
    """Lower end of its bracket or interval."""
    high: float
    how: str
    """In words, for the report."""
    boundary: MeasuredBoundary | None = None


def _done(g: pd.DataFrame) -> pd.DataFrame:
    return g[g["done"].astype(bool)]


def group_planner(group) -> str:
    """The planner of a search's group (a CellPlan): its grid value or its ``[planner]`` table's."""
    return str(group.settings.get("planner", {}).get("name", "straight"))


def folder_trials(folder: Path, planner: str) -> pd.DataFrame:
    """The finished trials of ``planner`` in a committed results folder: its trials.csv rows of the
    groups of its search.toml with that planner, and its repeats.csv rows of that planner."""
    from offroadbench.search.plan import load_search

    if not (folder / "search.toml").is_file() or not (folder / "trials.csv").is_file():
        raise InputError(f"reference_from = {str(folder)!r}: not a search results folder (no search.toml and trials.csv)")
    plan = load_search(folder / "search.toml")
    groups = [g.index for g in plan.groups if group_planner(g) == planner]
    run = pd.read_csv(folder / "trials.csv")
    parts = [run[run["group"].isin(groups)]]
    if (folder / "repeats.csv").is_file():
        rep = pd.read_csv(folder / "repeats.csv")
        parts.append(rep[rep["planner"] == planner])
    out = _done(pd.concat(parts, ignore_index=True))
    if not len(out):
        raise InputError(f"reference_from = {str(folder)!r}: no finished trial of planner {planner!r}")
    return out


def reference_interval(u: np.ndarray, failed: np.ndarray, param: SearchParam, n_boot: int = 1000,
                       level: float = 0.95) -> tuple[float, float]:
    """The percentile bootstrap interval (Efron & Tibshirani 1993, Ch. 13) of the boundary reference
    P under ``param``'s nominal: the trials resampled with replacement, the boundary measured again
    on each resample (its ends and its isotonic band) and integrated; the sampling error of the
    measured band, beside the bracket's model-free bounds. Deterministic (:data:`SEED`)."""
    u, f = np.asarray(u, dtype=float), np.asarray(failed, dtype=bool)
    rng = np.random.default_rng(SEED)
    ps = []
    for _ in range(n_boot):
        i = rng.integers(0, len(u), len(u))
        try:
            ps.append(measured_boundary(u[i], f[i]).probability(param))
        except ValueError:
            continue
    a = 1 - level
    lo, hi = np.quantile(ps, [a / 2, 1 - a / 2])
    return float(lo), float(hi)


def folder_reference(folder: Path, planner: str, cfg: SearchConfig, analysis: SearchAnalysis) -> Reference:
    """The reference of ``analysis.reference_from`` (module docstring): the boundary in
    ``boundary_param`` measured on the folder's trials of ``planner``, integrated against this
    search's nominal of that parameter (P, and the bracket [F(low), F(high)])."""
    d = folder_trials(folder, planner)
    key = analysis.boundary_param
    i = cfg.keys.index(key)
    b = measured_boundary(d[key].to_numpy(float), d["failed"].to_numpy(bool), i)
    lo, hi = b.bracket(cfg.params[i])
    return Reference(b.probability(cfg.params[i]), lo, hi,
                     f"measured boundary in `{key}` over the {b.trials} finished {planner} trials of "
                     f"{analysis.reference_from}: {b.describe()}, {b.band_failed} of the {b.band_trials} between "
                     f"failed (P = the nominal mass where failure is certain + the isotonic failure rate integrated "
                     f"over the band, under this search's nominal; bracket [{lo:.4g}, {hi:.4g}] whatever the band "
                     "does)", b)


def boundary_check(b: MeasuredBoundary, u: np.ndarray, failed: np.ndarray) -> dict:
    """The trials ``u`` (with outcomes ``failed``) against a boundary measured on others: how many lie
    where it says failure is certain and how many of those passed, how many lie beyond its band on
    the passing side and how many of those failed (each a trial the boundary did not predict), and
    the band's trials with their failures."""
    u, f = np.asarray(u, dtype=float), np.asarray(failed, dtype=bool)
    lo, hi = b.edges()
    certain = b.certain(u)
    safe = (b.sign * u) > b.high
    band = ~certain & ~safe
    return {"trials": len(u), "certain": int(certain.sum()), "certain passed": int((certain & ~f).sum()),
            "safe": int(safe.sum()), "safe failed": int((safe & f).sum()), "band": int(band.sum()),
            "band failed": int((band & f).sum()), "low": lo, "high": hi}


def reference(g: pd.DataFrame, cfg: SearchConfig, analysis: SearchAnalysis | None, planner: str | None = None,
              root: Path | None = None) -> Reference | None:
    """The reference P of one group's trials ``g`` (every method's) as ``analysis`` says (``mc``
    without a plan); None where it cannot be had (no ``random`` stream; nothing failed). With
    ``reference_from`` the boundary is the folder's (:func:`folder_reference`; the folder relative
    to ``root``, default the working directory, and ``planner`` the group's)."""
    d = _done(g)
    if analysis is not None and analysis.reference_from is not None:
        folder = (Path.cwd() if root is None else Path(root)) / analysis.reference_from
        return folder_reference(folder, planner or "straight", cfg, analysis)
    if analysis is not None and analysis.reference == "boundary":
        i = cfg.keys.index(analysis.boundary_param)
        try:
            b = measured_boundary(d[analysis.boundary_param].to_numpy(float), d["failed"].to_numpy(bool), i)
        except ValueError:
            return None
        lo, hi = b.bracket(cfg.params[i])
        return Reference(b.probability(cfg.params[i]), lo, hi,
                         f"measured boundary in `{analysis.boundary_param}` over all {b.trials} finished trials: "
                         f"{b.describe()}, {b.band_failed} of the {b.band_trials} between failed (P = the nominal "
                         f"mass where failure is certain + the isotonic failure rate integrated over the band; "
                         f"bracket [{lo:.4g}, {hi:.4g}] whatever the band does)", b)
    rnd = d[d["method"] == "random"]
    if not len(rnd):
        return None
    e = mc_estimate(rnd["failed"].to_numpy(bool), level=analysis.level if analysis else 0.95)
    return Reference(e.p, e.low, e.high, f"plain Monte Carlo, {e.failures} failures in {e.n} nominal trials "
                                         "(Clopper-Pearson interval)")


def is_summary(g: pd.DataFrame, cfg: SearchConfig, p_ref: float | None, level: float = 0.95) -> dict | None:
    """The ``ce-is`` stream's estimate (final stage), its normal and bootstrap-t intervals, and the
    gain at ``p_ref`` from its stated variance (None without a ``ce-is`` stream)."""
    ce = _done(g)
    ce = ce[ce["method"] == "ce-is"]
    if not len(ce):
        return None
    final = ce[ce["stage"] == "ce-final"]
    if not len(final):
        final = ce[ce["batch"] == ce["batch"].max()]
    f, lw = final["failed"].to_numpy(bool), final["log_w"].to_numpy(float)
    e: Estimate = is_estimate(f, lw, trials=len(ce), level=level)
    bt = bootstrap_t_interval(f, lw, level=level, seed=SEED)
    var = e.se ** 2 if math.isfinite(e.se) else math.nan
    gain = is_gain(p_ref, var, e.trials) if p_ref is not None else math.nan
    return {"estimate": e, "bootstrap_t": bt, "gain": gain,
            "covers_normal": (e.low <= p_ref <= e.high) if p_ref is not None else None,
            "covers_bootstrap_t": (bt[0] <= p_ref <= bt[1]) if p_ref is not None else None}


def mc_position(g: pd.DataFrame, cfg: SearchConfig, ref: Reference | None) -> dict | None:
    """Plain Monte Carlo against the reference: its estimate, its distance from the reference in its
    standard errors at the reference, and with a boundary the draws that fell where failure is
    certain (``below``: beyond the band on the failing side) against the n F(low) the nominal puts
    there (``expected_below``)."""
    d = _done(g)
    rnd = d[d["method"] == "random"]
    if not len(rnd) or ref is None:
        return None
    e = mc_estimate(rnd["failed"].to_numpy(bool))
    se_ref = math.sqrt(ref.p * (1 - ref.p) / e.n) if 0 < ref.p < 1 else math.nan
    out = {"estimate": e, "z": (e.p - ref.p) / se_ref if se_ref else math.nan, "below": None, "expected_below": None}
    if ref.boundary is not None:
        b = ref.boundary
        param = cfg.params[b.index]
        u = rnd[cfg.keys[b.index]].to_numpy(float)
        out["below"] = int(b.certain(u).sum())
        out["expected_below"] = e.n * b.certain_mass(param)
    return out


def falsifier_counts(g: pd.DataFrame, cfg: SearchConfig, ks: tuple[int, ...], ref: Reference | None,
                     streams: int = STREAMS) -> pd.DataFrame:
    """One row per count (the k-th failure for each k, and the k-th distinct failure under the
    study's rule for the largest k): the falsifier's trials (its one stream in ``g``), and each
    baseline's median with its 10-90 % range over ``streams`` streams: the ``uniform`` and
    ``random`` streams' pool orders where ``g`` has them (real trials), else streams computed from
    the measured boundary (``ref.boundary``)."""
    d = _done(g)
    fals = d[d["method"] == "falsify"]
    rng = np.random.default_rng(SEED)
    counts = [(f"{k}-th failure", k, False) for k in ks] + [(f"{max(ks)}-th distinct failure", max(ks), True)]
    rows = []
    for name, k, distinct in counts:
        dist = cfg.distinct_distance if distinct else None
        row = {"count": name, "falsify": trials_to_k(fals["failed"].to_numpy(bool), k, cfg.unit(
            fals[list(cfg.keys)].to_numpy(float)) if distinct else None, dist) if len(fals) else math.nan}
        for method, sampler in (("uniform", uniform_box(cfg)), ("random", nominal_draws(cfg))):
            s = d[d["method"] == method]
            if len(s):
                n = pool_streams(s["failed"].to_numpy(bool), k, streams, rng,
                                 cfg.unit(s[list(cfg.keys)].to_numpy(float)) if distinct else None, dist)
                how = f"orders of its {len(s)} trials"
            elif ref is not None and ref.boundary is not None:
                n = model_streams(cfg, ref.boundary, sampler, k, streams, rng, distinct=distinct)
                how = "computed from the boundary"
            else:
                row[f"{method} median"] = math.nan
                continue
            row[f"{method} median"] = float(np.median(n))
            q10, q90 = np.quantile(n, [0.1, 0.9], method="inverted_cdf")
            row[f"{method} 10-90 %"] = f"{q10:g}-{q90:g}"
            row[f"{method} streams"] = how
        rows.append(row)
    return pd.DataFrame(rows)


def modes(df: pd.DataFrame, cfg: SearchConfig, seed: int = SEED) -> tuple[list[Sensitivity], pd.DataFrame, pd.Series,
                                                                        pd.DataFrame]:
    """(sensitivity of each parameter, the failures, their modes, the mode table) of one group's
    finished trials ``df`` (module docstring of offroadbench.search.modes): the sensitivity from the
    ``random`` stream, else the ``uniform`` one, else every trial; the active parameters (every
    parameter where none is found active)."""
    d = _done(df)
    source = next((m for m in ("random", "uniform") if (d["method"] == m).any()), None)
    src = d[d["method"] == source] if source else d
    sens = sensitivity(src[list(cfg.keys)].to_numpy(float), src["failed"].to_numpy(bool), cfg.keys,
                       source or "every trial (not independent draws)", seed=seed)
    active = [s.key for s in sens if s.active] or list(cfg.keys)
    failures = d[d["failed"].astype(bool)]
    labels = failure_modes(failures, cfg, active)
    return sens, failures, labels, mode_table(failures, labels, cfg, active) if len(failures) else pd.DataFrame()


def stream_mode_rows(df: pd.DataFrame, labels: pd.Series) -> pd.DataFrame:
    """Per method stream in ``df``: trials, failures, modes found, trials to its first failure."""
    d = _done(df)
    rows = []
    for method, s in d.groupby("method", sort=False):
        found, first = stream_modes(s, labels)
        rows.append({"method": method, "trials": len(s), "failures": int(s["failed"].sum()), "modes found": found,
                     "trials to first failure": first})
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------- over repeats
def repeat_streams(run: pd.DataFrame, repeats: pd.DataFrame, method: str, group: int, planner: str) -> list[pd.DataFrame]:
    """Every stream of ``method``: the run's own (group ``group`` of ``run``, the search's trial table)
    first, then each replicate's in ``repeats`` (the results' repeats table: its ``planner`` and
    ``replicate`` columns name the stream), in replicate order."""
    own = run[(run["group"] == group) & (run["method"] == method)]
    out = [own.reset_index(drop=True)] if len(own) else []
    reps = repeats[(repeats["planner"] == planner) & (repeats["method"] == method)]
    out += [r.assign(group=group).reset_index(drop=True) for _, r in reps.groupby("replicate", sort=True)]
    return out


def pooled_reference(run: pd.DataFrame, repeats: pd.DataFrame, cfg: SearchConfig, analysis: SearchAnalysis,
                     group: int, planner: str) -> Reference | None:
    """The reference from every finished trial of the group, the run's and every repeat's (each
    outcome at its parameters is data, whoever proposed it)."""
    reps = repeats[repeats["planner"] == planner].assign(group=group)
    both = pd.concat([run[run["group"] == group], reps], ignore_index=True)
    return reference(both, cfg, analysis)


def is_repeats(streams: list[pd.DataFrame], cfg: SearchConfig, p_ref: float, level: float = 0.95) -> pd.DataFrame:
    """One row per importance-sampling stream: its estimate, relative error, normal and bootstrap-t
    intervals, whether each holds ``p_ref``, and its gain at ``p_ref`` from its stated error."""
    rows = []
    for i, s in enumerate(streams):
        r = is_summary(s, cfg, p_ref, level)
        e = r["estimate"]
        rows.append({"stream": i, "P": e.p, "failures": e.failures, "final draws": e.n, "trials": e.trials,
                     "stated rel. error": e.rel_error, "normal low": e.low, "normal high": e.high,
                     "bootstrap-t low": r["bootstrap_t"][0], "bootstrap-t high": r["bootstrap_t"][1],
                     "normal holds the reference": bool(r["covers_normal"]),
                     "bootstrap-t holds the reference": bool(r["covers_bootstrap_t"]),
                     "stated gain at the reference": r["gain"]})
    return pd.DataFrame(rows)


def spread_gain(ps: np.ndarray, p_ref: float, trials: int, n_boot: int = 2000, level: float = 0.95) -> tuple[float, float, float, float]:
    """(relative RMSE about ``p_ref``, gain, lower, upper): the work-normalised gain from the mean
    squared error of repeated estimates, p (1 - p) / (trials MSE), with the percentile bootstrap
    interval over the repeats (Efron & Tibshirani 1993, Ch. 13)."""
    ps = np.asarray(ps, dtype=float)
    mse = float(np.mean((ps - p_ref) ** 2))
    rng = np.random.default_rng(SEED)
    boot = np.array([np.mean((ps[rng.integers(0, len(ps), len(ps))] - p_ref) ** 2) for _ in range(n_boot)])
    g = is_gain(p_ref, mse, trials)
    a = 1 - level
    b_lo, b_hi = np.quantile(boot, [1 - a / 2, a / 2])  # a larger MSE is a smaller gain
    return math.sqrt(mse) / p_ref, g, is_gain(p_ref, float(b_lo), trials), is_gain(p_ref, float(b_hi), trials)


def stream_counts(streams: list[pd.DataFrame], cfg: SearchConfig, ks: tuple[int, ...]) -> pd.DataFrame:
    """Per stream: trials to the k-th failure for each k, and to the largest k's distinct failure
    (inf where it never got there)."""
    rows = []
    for i, s in enumerate(streams):
        d = _done(s)
        f = d["failed"].to_numpy(bool)
        row = {"stream": i, "trials": len(d)}
        for k in ks:
            row[f"{k}-th failure"] = trials_to_k(f, k)
        k = max(ks)
        row[f"{k}-th distinct failure"] = trials_to_k(f, k, cfg.unit(d[list(cfg.keys)].to_numpy(float)),
                                                      cfg.distinct_distance)
        rows.append(row)
    return pd.DataFrame(rows)


def results_figures(run: pd.DataFrame, repeats: pd.DataFrame, cfg: SearchConfig, analysis: SearchAnalysis,
                    group: int, planner: str, streams: int = STREAMS, root: Path | None = None) -> dict:
    """The committed figures of one planner of a results folder (its trial table ``run`` and its
    repeats table): the pooled reference, the importance-sampling repeats with both intervals and
    the gains, the falsifier's streams against real uniform streams (the ``uniform`` replicates),
    nominal pool orders and streams computed from the boundary, and the failure modes over every
    trial. With ``[analysis] reference_from`` the reference is that folder's boundary (relative to
    ``root``; :func:`folder_reference`), with its bootstrap interval (``reference_interval``) and
    this folder's trials checked against it (``check``: :func:`boundary_check`) and the boundary
    its own trials measure (``own reference``: not independent of the estimates); the falsifier's
    figures only where the folder has falsifier streams. Deterministic."""
    ks = analysis.first_k
    both = pd.concat([run[run["group"] == group], repeats[repeats["planner"] == planner].assign(group=group)],
                     ignore_index=True)
    if analysis.reference_from is not None:
        ref = reference(both, cfg, analysis, planner, root)
        src = folder_trials((Path.cwd() if root is None else Path(root)) / analysis.reference_from, planner)
        key = analysis.boundary_param
        param = cfg.params[cfg.keys.index(key)]
        d = _done(both)
        out: dict = {"reference": ref,
                     "reference_interval": reference_interval(src[key].to_numpy(float), src["failed"].to_numpy(bool),
                                                              param, level=analysis.level),
                     "check": boundary_check(ref.boundary, d[key].to_numpy(float), d["failed"].to_numpy(bool)),
                     "own reference": reference(both, cfg, dataclasses.replace(analysis, reference_from=None))}
    else:
        ref = pooled_reference(run, repeats, cfg, analysis, group, planner)
        out = {"reference": ref}
    ce = repeat_streams(run, repeats, "ce-is", group, planner)
    if ce:
        tab = is_repeats(ce, cfg, ref.p, analysis.level)
        trials = int(tab["trials"].iloc[0])
        rmse, g, g_lo, g_hi = spread_gain(tab["P"].to_numpy(), ref.p, trials, level=analysis.level)
        out["is"] = tab
        out["is_summary"] = {"runs": len(tab), "mean P": float(tab["P"].mean()), "rel. RMSE": rmse, "gain": g,
                             "gain low": g_lo, "gain high": g_hi,
                             "median stated gain": float(tab["stated gain at the reference"].median()),
                             "normal holds": int(tab["normal holds the reference"].sum()),
                             "bootstrap-t holds": int(tab["bootstrap-t holds the reference"].sum())}
    fals = stream_counts(repeat_streams(run, repeats, "falsify", group, planner), cfg, ks)
    if not len(fals):
        out["sensitivity"], out["modes"] = modes(both, cfg)[0::3]
        return out
    uni = stream_counts(repeat_streams(run, repeats, "uniform", group, planner), cfg, ks)
    rng = np.random.default_rng(SEED)
    d = _done(run[run["group"] == group])
    pool = d[d["method"] == "random"]
    rows = []
    for col in [c for c in fals.columns if c not in ("stream", "trials")]:
        k = int(col.split("-")[0])
        distinct = "distinct" in col
        dist = cfg.distinct_distance if distinct else None
        f_med = float(np.median(fals[col]))
        f_lo, f_hi, f_cov = median_interval(fals[col].to_numpy(float), analysis.level)
        row = {"count": col, "falsifier streams": len(fals), "falsifier median": f_med, "falsifier low": f_lo,
               "falsifier high": f_hi, "falsifier coverage": f_cov}
        model_u = model_streams(cfg, ref.boundary, uniform_box(cfg), k, streams, rng, distinct=distinct)
        model_n = model_streams(cfg, ref.boundary, nominal_draws(cfg), k, streams, rng, distinct=distinct)
        orders = pool_streams(pool["failed"].to_numpy(bool), k, streams, rng,
                              cfg.unit(pool[list(cfg.keys)].to_numpy(float)) if distinct else None, dist)
        for name, values, independent in (("uniform, real streams", uni[col].to_numpy(float) if len(uni) else None, True),
                                          ("uniform, computed", model_u, True),
                                          ("nominal, computed", model_n, True),
                                          ("nominal, orders of the Monte Carlo pool", orders, False)):
            if values is None:
                continue
            med = float(np.median(values))
            row[f"{name}: streams"] = len(values)
            row[f"{name}: median"] = med
            if independent:
                r, lo, hi, cov = ratio_interval(values, fals[col].to_numpy(float), analysis.level)
                row[f"{name}: ratio"], row[f"{name}: ratio low"], row[f"{name}: ratio high"] = r, lo, hi
                row[f"{name}: joint coverage"] = cov
            else:
                row[f"{name}: ratio"] = med / f_med
        rows.append(row)
    out["falsifier"] = fals
    out["uniform"] = uni
    out["baselines"] = pd.DataFrame(rows)
    sens, _, _, table = modes(both, cfg)
    out["sensitivity"], out["modes"] = sens, table
    return out
