"""Failure modes: which searched parameters a failure depends on, and the failures grouped into
modes in those parameters alone.

**Which parameters matter** (:func:`sensitivity`). For the failure indicator Y = 1{fail} and one
searched parameter X_i, the first-order sensitivity index S_i = V(E[Y | X_i]) / V(Y) (Sobol' 1993;
Saltelli et al. 2008, Ch. 4: the share of Y's variance that X_i alone explains) is estimated
from independent draws by the correlation ratio eta^2 of Y on B equal-count bins of X_i (Pearson
1905; the "given data" estimator of Plischke 2010):

    eta_i^2 = sum_b n_b (ybar_b - ybar)^2 / sum_j (y_j - ybar)^2.

(B = 10, or n / 5 with fewer than 50 draws, so that a bin holds 5 draws at least). Under
independence eta^2 is not 0 but about (B - 1) / (n - 1), so a parameter is **active** when
its eta^2 exceeds the ``1 - alpha`` quantile of eta^2 over random permutations of Y (the same
bins and failures with the dependence destroyed: a permutation test of independence, Good
2005), and **inactive** otherwise. The draws are a stream of independent draws (``random``,
the nominal: S_i under the operational domain; else ``uniform``, the box); a falsifier's draws
are not independent and are not used. First-order only: a parameter that matters only together
with another (an interaction) is missed, so a dimension is dropped on the data's word, never
silently (the report prints every eta^2 and its permutation threshold).

**Modes** (:func:`failure_modes`). The failures of every stream, scaled to [0, 1] on each range and
restricted to the active parameters, are grouped by single linkage at the study's distinct
distance h (Chebyshev): two failures are in one mode when a chain of failures, each within h of
the next in every active parameter, joins them (the connected components of the h-neighbour graph;
single-linkage clustering cut at height h, Gower & Ross 1969; DBSCAN with one point per core,
Ester et al. 1996). A mode is a region of failure as the searches resolved it at the study's own
resolution; dropping the inactive parameters means ten failures at ten cruise speeds and one
friction are one mode, not ten. Each mode is reported with its extent in every searched parameter,
its size, which streams found it and when, and a representative failure (the medoid in the active
parameters: the failure with the smallest summed distance to the mode's others) to replay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from offroadbench.search.space import SearchConfig

__all__ = ["Sensitivity", "sensitivity", "correlation_ratio", "single_linkage", "failure_modes", "mode_table",
           "stream_modes"]

#: equal-count bins of a parameter for the correlation ratio
BINS = 10
#: permutations of the failure indicator for the activity threshold
PERMUTATIONS = 999
#: the test's level: a parameter is active when its eta^2 exceeds the (1 - ALPHA) permutation quantile
ALPHA = 0.01


def _bins(x: np.ndarray, bins: int) -> np.ndarray:
    """Equal-count bin of each value (by rank; ties broken by order)."""
    x = np.asarray(x, dtype=float).ravel()
    return np.minimum((np.argsort(np.argsort(x, kind="stable"), kind="stable") * bins) // max(len(x), 1), bins - 1)


def correlation_ratio(x: np.ndarray, y: np.ndarray, bins: int = BINS) -> float:
    """eta^2 of y on ``bins`` equal-count bins of x (module docstring); 0 where y is constant."""
    return _eta2(_bins(x, bins), np.asarray(y, dtype=float).ravel(), bins)


def _eta2(b: np.ndarray, y: np.ndarray, bins: int) -> float:
    ss = float(((y - y.mean()) ** 2).sum())
    if ss == 0 or len(y) < 2:
        return 0.0
    n_b = np.bincount(b, minlength=bins)
    s_b = np.bincount(b, weights=y, minlength=bins)
    mean_b = np.divide(s_b, n_b, out=np.zeros(bins), where=n_b > 0)
    return float((n_b * (mean_b - y.mean()) ** 2).sum() / ss)


@dataclass(frozen=True)
class Sensitivity:
    """eta^2 of one parameter, its permutation threshold, and the verdict."""

    key: str
    eta2: float
    threshold: float
    """The (1 - ALPHA) quantile of eta^2 over permutations of the failure indicator."""
    p_value: float
    """(1 + permutations at or above eta^2) / (1 + permutations)."""
    active: bool
    draws: int
    failures: int
    source: str
    """The stream the draws came from (``random`` or ``uniform``)."""


def sensitivity(x: np.ndarray, failed: np.ndarray, keys: tuple[str, ...], source: str, *, bins: int = BINS,
                permutations: int = PERMUTATIONS, alpha: float = ALPHA, seed: int = 0) -> list[Sensitivity]:
    """Per parameter (a column of ``x``, independent draws): eta^2 of the failure indicator and whether
    it exceeds the permutation threshold (module docstring). Deterministic (``seed``)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    y = np.asarray(failed, dtype=float).ravel()
    bins = max(2, min(bins, len(y) // 5))  # at least 5 draws a bin: with fewer eta^2 is 1 for any y
    rng = np.random.default_rng(seed)
    perms = [rng.permutation(y) for _ in range(permutations)]
    out = []
    for i, key in enumerate(keys):
        b = _bins(x[:, i], bins)
        eta = _eta2(b, y, bins)
        null = np.array([_eta2(b, yp, bins) for yp in perms])
        thr = float(np.quantile(null, 1 - alpha))
        p = (1 + int((null >= eta).sum())) / (1 + permutations)
        out.append(Sensitivity(key, eta, thr, p, bool(y.any() and eta > thr), len(y), int(y.sum()), source))
    return out


def single_linkage(u: np.ndarray, h: float) -> np.ndarray:
    """Mode label of each row of ``u`` (points in [0, 1] units): connected components of the graph
    joining points closer than ``h`` (Chebyshev), labelled 0, 1, ... in order of each component's
    first row."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    u = np.atleast_2d(np.asarray(u, dtype=float))
    n = len(u)
    if n == 0:
        return np.empty(0, dtype=int)
    pairs = [(np.nonzero(np.max(np.abs(u[i + 1:] - u[i]), axis=1) < h)[0] + i + 1 if u.shape[1]
              else np.arange(i + 1, n)) for i in range(n)]
    rows = np.repeat(np.arange(n), [len(c) for c in pairs])
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, np.concatenate(pairs))), shape=(n, n))
    _, roots = connected_components(graph, directed=False)
    labels = np.empty(n, dtype=int)
    seen: dict[int, int] = {}
    for i, r in enumerate(roots):
        labels[i] = seen.setdefault(int(r), len(seen))
    return labels


def failure_modes(failures: pd.DataFrame, cfg: SearchConfig, active: list[str]) -> pd.Series:
    """Mode of each failure (rows of ``failures``, in their order) by single linkage at the study's
    distinct distance over the ``active`` parameters (module docstring)."""
    idx = [cfg.keys.index(k) for k in active]
    u = cfg.unit(failures[list(cfg.keys)].to_numpy(dtype=float))[:, idx] if len(failures) else np.zeros((0, len(idx)))
    return pd.Series(single_linkage(u, cfg.distinct_distance), index=failures.index, name="mode")


def _medoid(u: np.ndarray) -> int:
    if len(u) == 1 or u.shape[1] == 0:
        return 0
    d = np.max(np.abs(u[:, None, :] - u[None, :, :]), axis=2).sum(axis=1)
    return int(np.argmin(d))


def mode_table(failures: pd.DataFrame, modes: pd.Series, cfg: SearchConfig, active: list[str]) -> pd.DataFrame:
    """One row per mode: failures, the extent of every searched parameter, the failure reasons, the
    methods that found it, and its representative failure (cell, parameters): the medoid in the
    active parameters among the failures with a stored cell (None where no failure has one)."""
    idx = [cfg.keys.index(k) for k in active]
    rows = []
    for m in sorted(modes.unique()):
        f = failures[modes == m]
        # the representative: the medoid among the failures that can be replayed (a stored cell;
        # a repeat's trials in a results table have none), else among all
        pick = f[f["cell"].notna()] if "cell" in f and f["cell"].notna().any() else f
        u = cfg.unit(pick[list(cfg.keys)].to_numpy(dtype=float))[:, idx]
        rep = pick.iloc[_medoid(u)]
        row = {"mode": int(m), "failures": len(f)}
        for k in cfg.keys:
            row[f"{k} range"] = f"{f[k].min():.4g}-{f[k].max():.4g}"
        row["reasons"] = ", ".join(f"{r} {n}" for r, n in f["failure_reason"].value_counts().items())
        row["found by"] = ", ".join(sorted(f["method"].unique()))
        row["representative cell"] = int(rep["cell"]) if "cell" in rep and pd.notna(rep["cell"]) else None
        for k in cfg.keys:
            row[f"representative {k}"] = float(rep[k])
        rows.append(row)
    return pd.DataFrame(rows)


def stream_modes(stream: pd.DataFrame, modes: pd.Series) -> tuple[int, float]:
    """(modes a stream found, trials it spent to its first failure; NaN if none): ``stream`` its
    finished trials in order, ``modes`` the mode of every failure by row index."""
    failed = stream["failed"].to_numpy(dtype=bool)
    hit = np.nonzero(failed)[0]
    found = modes.reindex(stream.index[failed]).dropna().nunique()
    return int(found), float(hit[0] + 1) if len(hit) else math.nan
