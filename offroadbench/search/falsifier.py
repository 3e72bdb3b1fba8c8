"""Proposals of a failure search, batch by batch (ask/tell), rebuilt from the stored trials.

A search runs *streams*: one per (grid cell, method). Batch b of a stream is a pure function of
the search config, the stream's seed, b and the results of batches 0..b-1 (:class:`Batch`), so the
optimiser's state never has to be saved: after a kill, :func:`propose` rebuilds it from the stored
trials and gives the same proposals again (tests/search/test_runner.py kills and resumes a search).

* ``falsify`` with ``sampler = "tpe"``: optuna's TPE sampler (Bergstra et al. 2011; multivariate,
  Falkner et al. 2018) seeded per batch, told every earlier trial (``create_trial``) and asked
  ``n`` times with the constant liar (Ginsbourger et al. 2010), so one batch spreads out. It
  minimises the margin (offroadbench.search.objective) over the parameters' ranges.
* ``falsify`` with ``sampler = "cmaes"``: CMA-ES (Hansen 2016) of the ``cmaes`` package on the
  ranges scaled to [0, 1], its population one batch; the state is rebuilt by replaying every
  earlier generation's ask and tell (the package's generator is seeded, so the replay is exact).
* ``falsify`` with ``local_step > 0`` (TPE): once a stream has a failure (and has run its
  ``startup_trials``), each batch keeps
  ``explore_slots`` proposals of the optimiser (fresh terrains) and fills the rest by a local
  pattern search (a compass search, Kolda et al. 2003, Sec. 3) around the failures found so far:
  a failure's parameters moved by ``local_step`` of a range along one parameter at a time, on the
  failure's own terrain and mission seeds (``local_terrain = "fresh"``: on the stream's next fresh
  terrain, like the optimiser's proposals), the parameters whose moves kept failures so far first.
  The operational domain lets the terrain and mission vary, so the falsifier may pick them (the
  nominal distribution only weighs the P(failure) estimates, which never use the falsifier's
  trials). A neighbour closer than ``distinct_distance`` to a point already tried on the same
  terrain is skipped, so a neighbour that fails is distinct from every failure on its terrain.
* ``random``: nominal draws (plain Monte Carlo).
* ``uniform``: uniform draws on the parameters' ranges, the falsifier's own search box: the naive
  search it is measured against (offroadbench.search.baselines). Its log likelihood ratios are
  those of the nominal against the uniform density, so its trials also estimate P(failure) by
  importance sampling, though nothing reports that estimate.
* ``ce-is``: cross-entropy stages, then importance sampling from the defensive mixture
  (offroadbench.search.estimators).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from offroadbench import seeding
from offroadbench.search.estimators import GaussianProposal, ce_adapt
from offroadbench.search.space import METHODS, SearchConfig

__all__ = ["Batch", "Proposal", "SEARCH_STREAM", "stream_seed", "plan_batch", "propose"]

#: first spawn-key entry of a search's own seeds (the study's streams are 0 and 1)
SEARCH_STREAM = 7


@dataclass(frozen=True, eq=False)
class Batch:
    """A finished batch of a stream: what was proposed and how each trial ended."""

    stage: str
    """``falsify``, ``random``, ``ce-stage`` (an adaptive cross-entropy stage) or ``ce-final``."""
    x: np.ndarray
    """Parameter values (n, d)."""
    z: np.ndarray
    """Their standard-normal coordinates (n, d)."""
    margin: np.ndarray
    """The failure margin of each trial (n,); negative = failed."""
    seeds: tuple[tuple[int, int] | None, ...] = ()
    """(terrain seed, mission seed) each trial drove (None where not known: a trial without a row)."""


@dataclass(frozen=True, eq=False)
class Proposal:
    """The next batch of a stream, before it runs."""

    stage: str
    x: np.ndarray
    """Parameter values (n, d), inside every range."""
    z: np.ndarray
    """Standard-normal coordinates (n, d)."""
    log_w: np.ndarray
    """log(nominal density / proposal density) of each point, in z (n,): 0 for nominal draws, NaN
    for the falsifier (its points come from no stated density)."""
    seeds: tuple[tuple[int, int] | None, ...] = ()
    """(terrain seed, mission seed) a point must drive (the falsifier's local search re-drives a
    failure's terrain), None (or a short tuple) where the stream's own nuisance draw applies."""


def stream_seed(root_seed: int, group: int, method: str, replicate: int = 0) -> int:
    """The integer seed of one stream (grid cell ``group``, ``method``; ``replicate`` of
    SearchConfig, 0 the original streams)."""
    if replicate:
        return seeding.derive_seed(root_seed, SEARCH_STREAM, group, METHODS.index(method), replicate)
    return seeding.derive_seed(root_seed, SEARCH_STREAM, group, METHODS.index(method))


def _batch_rng(seed: int, batch: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(batch,)))


def plan_batch(method: str, cfg: SearchConfig, history: list[Batch], budget: int) -> tuple[str, int]:
    """(stage, size) of the next batch of a stream that has run ``history``; size 0 when the
    stream has spent ``budget``."""
    used = sum(len(b.margin) for b in history)
    left = budget - used
    if left <= 0:
        return method, 0
    if method != "ce-is":
        return method, min(cfg.batch_size, left)
    if any(b.stage == "ce-final" for b in history):
        return "ce-final", min(cfg.batch_size, left)
    _, adapted = _ce_state(cfg, history)
    if not adapted and cfg.ce_stage_size < left:
        return "ce-stage", cfg.ce_stage_size
    return "ce-final", min(cfg.batch_size, left)


def _ranked_last(margin: np.ndarray) -> np.ndarray:
    """Margins with the NaN of no-mission draws replaced by more than the largest finite one (ranked last)."""
    m = np.asarray(margin, dtype=float)
    finite = m[np.isfinite(m)]
    return np.where(np.isfinite(m), m, (finite.max() if finite.size else 0.0) + 1.0)


def _ce_state(cfg: SearchConfig, history: list[Batch]) -> tuple[GaussianProposal, bool]:
    stages = [(b.z, _ranked_last(b.margin)) for b in history if b.stage == "ce-stage"]
    return ce_adapt(stages, cfg.dim, quantile=cfg.ce_quantile, min_sd=cfg.ce_min_sd, max_stages=cfg.ce_max_stages,
                    initial_sd=cfg.ce_initial_sd, min_failures=cfg.ce_min_failures, min_stages=cfg.ce_min_stages,
                    pool_weights=cfg.ce_pool_weights)


def propose(method: str, stage: str, n: int, cfg: SearchConfig, seed: int, batch: int, history: list[Batch]) -> Proposal:
    """Batch ``batch`` (``n`` points, ``stage`` from :func:`plan_batch`) of a stream with seed ``seed``
    whose earlier batches are ``history``."""
    rng = _batch_rng(seed, batch)
    d = cfg.dim
    if stage == "random":
        z = rng.standard_normal((n, d))
        return Proposal(stage, cfg.from_z(z), z, np.zeros(n))
    if stage == "uniform":
        lo = np.array([p.low for p in cfg.params])
        hi = np.array([p.high for p in cfg.params])
        x = lo + rng.random((n, d)) * (hi - lo)
        log_w = sum(np.log(p.pdf(x[:, i]) * (p.high - p.low)) for i, p in enumerate(cfg.params))
        return Proposal(stage, x, cfg.to_z(x), np.asarray(log_w, dtype=float))
    if stage in ("ce-stage", "ce-final"):
        prop, _ = _ce_state(cfg, history)
        if stage == "ce-final":
            prop = prop.with_defensive(cfg.ce_defensive)
        z = prop.sample(n, rng)
        return Proposal(stage, cfg.from_z(z), z, prop.log_weight(z))
    if stage != "falsify":
        raise ValueError(f"unknown stage {stage!r}")
    local = _local_moves(cfg, history, n - min(cfg.explore_slots, n)) if cfg.local_step > 0 else []
    n_opt = n - len(local)
    x_opt = np.zeros((0, d))
    if n_opt:
        x_opt = _tpe(cfg, seed, batch, history, n_opt) if cfg.sampler == "tpe" else _cma(cfg, seed, history, n_opt)
    x = x_opt
    if local:
        x = np.vstack([x_opt, _from_unit(cfg, np.array([u for u, _ in local]))])
    seeds = tuple([None] * n_opt + [s for _, s in local])
    return Proposal(stage, x, cfg.to_z(x), np.full(n, np.nan), seeds)


def _from_unit(cfg: SearchConfig, u: np.ndarray) -> np.ndarray:
    lo = np.array([p.low for p in cfg.params])
    hi = np.array([p.high for p in cfg.params])
    return np.clip(lo + np.asarray(u, dtype=float) * (hi - lo), lo, hi)


def _move_axis(u: np.ndarray, earlier: list[int], xs: list[np.ndarray]) -> tuple[int, int] | None:
    """(axis, parent index) of a compass move: the first earlier point on the same terrain that
    differs from ``u`` in exactly one parameter (None if there is none)."""
    for k in earlier:
        diff = np.abs(u - xs[k]) > 1e-9
        if int(diff.sum()) == 1:
            return int(np.argmax(diff)), k
    return None


def _local_moves(cfg: SearchConfig, history: list[Batch], slots: int) -> list[tuple[np.ndarray, tuple[int, int]]]:
    """Up to ``slots`` compass moves around the stream's failures (module docstring): (point in
    range units, (terrain seed, mission seed)) each. A move along parameter j is ranked by how
    often moves along j from a failure failed too so far ((kept + 1) / (moves + 2): a parameter
    that changes the terrain, such as its roughness, loses the failure; one that does not, keeps
    it), then by its failure's margin (deepest first), parameter order and + before -."""
    if slots <= 0:
        return []
    xs: list[np.ndarray] = []
    ms: list[float] = []
    seeds: list = []
    for b in history:
        if len(b.seeds) != len(b.margin):
            continue
        xs.extend(np.asarray(u, dtype=float) for u in cfg.unit(b.x))
        ms.extend(float(m) for m in b.margin)
        seeds.extend(None if s is None else tuple(s) for s in b.seeds)
    on_terrain: dict[tuple[int, int], list[int]] = {}
    moves, kept = np.zeros(cfg.dim), np.zeros(cfg.dim)
    for i, s in enumerate(seeds):
        if s is None:
            continue
        earlier = on_terrain.setdefault(s, [])
        move = _move_axis(xs[i], earlier, xs) if earlier else None
        if move is not None and np.isfinite(ms[move[1]]) and ms[move[1]] < 0 and np.isfinite(ms[i]):
            moves[move[0]] += 1
            kept[move[0]] += ms[i] < 0
        earlier.append(i)
    keep_rate = (kept + 1) / (moves + 2)
    parents = [i for i, m in enumerate(ms) if np.isfinite(m) and m < 0 and seeds[i] is not None]
    candidates = []
    for i in parents:
        for j in range(cfg.dim):
            for sign in (1.0, -1.0):
                candidates.append((-keep_rate[j], ms[i], i, j, -sign))
    candidates.sort()
    fresh = cfg.local_terrain == "fresh"
    out: list[tuple[np.ndarray, tuple[int, int] | None]] = []
    for _, _, i, j, neg_sign in candidates:
        u = xs[i].copy()
        u[j] = min(max(u[j] - neg_sign * cfg.local_step, 0.0), 1.0)
        near = range(len(xs)) if fresh else on_terrain[seeds[i]]
        if all(np.max(np.abs(u - xs[t])) >= cfg.distinct_distance for t in near) and \
                all(np.max(np.abs(u - v)) >= cfg.distinct_distance for v, s in out if fresh or s == seeds[i]):
            out.append((u, None if fresh else seeds[i]))
            if len(out) == slots:
                break
    return out


def _tpe(cfg: SearchConfig, seed: int, batch: int, history: list[Batch], n: int) -> np.ndarray:
    import optuna
    from optuna.distributions import FloatDistribution

    dists = {p.key: FloatDistribution(p.low, p.high) for p in cfg.params}
    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # one in-memory optuna study per batch: not news
    try:
        return _tpe_ask(cfg, seed, batch, history, n, dists)
    finally:
        optuna.logging.set_verbosity(verbosity)


def _tpe_ask(cfg: SearchConfig, seed: int, batch: int, history: list[Batch], n: int, dists) -> np.ndarray:
    import optuna

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # optuna's ExperimentalWarning for multivariate and constant_liar
        sampler = optuna.samplers.TPESampler(seed=int(seeding.derive_seed(seed, batch) % 2**32),
                                             n_startup_trials=cfg.startup_trials, multivariate=True,
                                             constant_liar=True)
        study = optuna.create_study(direction="minimize", sampler=sampler)
        done = [optuna.trial.create_trial(params=cfg.values(xi), distributions=dists, value=float(mi))
                for b in history for xi, mi in zip(b.x, b.margin, strict=True) if np.isfinite(mi)]  # no-mission draws: not told
        if done:
            study.add_trials(done)
        out = []
        for _ in range(n):
            trial = study.ask(dists)
            out.append([trial.params[k] for k in cfg.keys])
    return np.clip(np.asarray(out, dtype=float), [p.low for p in cfg.params], [p.high for p in cfg.params])


def _cma(cfg: SearchConfig, seed: int, history: list[Batch], n: int) -> np.ndarray:
    from cmaes import CMA

    d = cfg.dim
    opt = CMA(mean=np.full(d, 0.5), sigma=0.25, bounds=np.tile([0.0, 1.0], (d, 1)), seed=int(seed % 2**31),
              population_size=cfg.batch_size)
    for b in history:  # replay every earlier generation: same asks, same tells
        u = cfg.unit(b.x)
        for _ in range(len(b.margin)):
            opt.ask()
        if len(b.margin) == opt.population_size:
            m = _ranked_last(b.margin)
            opt.tell([(u[i], float(m[i])) for i in range(len(u))])
    u = np.array([opt.ask() for _ in range(n)])
    lo = np.array([p.low for p in cfg.params])
    hi = np.array([p.high for p in cfg.params])
    return np.clip(lo + u * (hi - lo), lo, hi)
