"""The figures a search's analysis plan names, from a table of finished trials (the report's for one
run; a results folder's, run and repeats, for the committed figures).

* :func:`reference`: the reference P the estimates are judged at, obtained as the plan says
  (``boundary``: offroadbench.search.baselines.MeasuredBoundary over every finished trial of the
  group, whoever proposed it: an outcome at a parameter value is data; ``mc``: the ``random``
  stream's estimate).
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

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from offroadbench.search.analysis import SearchAnalysis
from offroadbench.search.baselines import (MeasuredBoundary, measured_boundary, model_streams, nominal_draws,
                                           pool_streams, trials_to_k, uniform_box)
from offroadbench.search.estimators import Estimate, bootstrap_t_interval, is_estimate, is_gain, mc_estimate
from offroadbench.search.modes import Sensitivity, failure_modes, mode_table, sensitivity, stream_modes
from offroadbench.search.space import SearchConfig

__all__ = ["Reference", "reference", "is_summary", "mc_position", "falsifier_counts", "modes", "STREAMS", "SEED"]

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


def reference(g: pd.DataFrame, cfg: SearchConfig, analysis: SearchAnalysis | None) -> Reference | None:
    """The reference P of one group's trials ``g`` (every method's) as ``analysis`` says (``mc``
    without a plan); None where it cannot be had (no ``random`` stream; nothing failed)."""
    d = _done(g)
    if analysis is not None and analysis.reference == "boundary":
        i = cfg.keys.index(analysis.boundary_param)
        try:
            b = measured_boundary(d[analysis.boundary_param].to_numpy(float), d["failed"].to_numpy(bool), i)
        except ValueError:
            return None
        lo, hi = b.bracket(cfg.params[i])
        return Reference(b.probability(cfg.params[i]), lo, hi,
                         f"measured boundary in `{analysis.boundary_param}` over all {b.trials} finished trials: every "
                         f"trial below {b.low:.4g} failed, every one above {b.high:.4g} passed, {b.band_failed} of the "
                         f"{b.band_trials} between failed (P = F(low) + the isotonic failure rate integrated over the "
                         f"band; bracket [F(low), F(high)] = [{lo:.4g}, {hi:.4g}] whatever the band does)", b)
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
    certain (below the boundary's low end) against the n F(low) the nominal puts there."""
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
        out["below"] = int((u < b.low).sum())
        out["expected_below"] = float(e.n * param.cdf(np.array([b.low]))[0])
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
