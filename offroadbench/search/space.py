"""The search space of a failure search: the ``[search]`` table of a study TOML.

A search file is a study file (``[study]``, ``[recipe_overrides]``, the settings tables and an
optional small ``[grid]``, whose cells are searched one after another: e.g. one per planner)
plus a ``[search]`` table and one ``[[search.params]]`` table per searched key::

    [search]
    methods = ["falsify", "random", "ce-is"]
    budget = 200                 # trials per method and grid cell
    batch_size = 8

    [[search.params]]
    key = "recipe.layers.base.D_high"
    low = 2.30
    high = 2.60
    nominal = "normal"           # or "uniform"
    mean = 2.40
    sd = 0.05

A parameter's ``[low, high]`` range bounds the search (the falsifier proposes only inside it);
its nominal distribution (uniform on the range, or a normal truncated to it) is the operational
domain under which P(failure) is estimated. The terrain and the mission of every trial are random
nuisance (drawn from the study's seed rules, :mod:`offroadbench.seeding`), unless ``fix_terrain``
/ ``fix_mission`` pin them to terrain 0 / mission 0.

The importance-sampling estimator works in standard-normal coordinates: ``z = Phi^-1(F(x))`` with
``F`` the nominal CDF of the parameter, so the nominal distribution of every space is N(0, I)
(the Rosenblatt transform of independent parameters; Rubinstein & Kroese 2004, Sec. 3.4, for the
cross-entropy method it feeds).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from scipy import special

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError
from offroadbench.search.estimators import POOL_WEIGHTS

__all__ = ["METHODS", "SAMPLERS", "NOMINALS", "SearchParam", "SearchConfig", "search_from_dict"]

#: what a search runs, per grid cell: the falsifier, nominal (plain Monte Carlo) sampling, the
#: cross-entropy importance-sampling estimate of P(failure), and uniform sampling of the falsifier's
#: own search box (the naive search: the falsifier's baseline, offroadbench.search.baselines)
METHODS = ("falsify", "random", "ce-is", "uniform")
#: the falsifier's optimiser: optuna's TPE, or CMA-ES (the ``cmaes`` package)
SAMPLERS = ("tpe", "cmaes")
#: nominal distributions of a parameter on its range
NOMINALS = ("uniform", "normal")
#: where the falsifier's local moves drive: the failure's own terrain, or a fresh one
LOCAL_TERRAINS = ("same", "fresh")
#: what the falsifier minimises (offroadbench.search.objective)
OBJECTIVES = ("margin",)
#: settings tables whose fields a parameter may name (one level deep, numbers only)
_SETTINGS_TARGETS = ("missions", "controller", "vehicle", "rules", "sim", "roughness", "planner")


@dataclass(frozen=True, kw_only=True)
class SearchParam:
    """One searched key: its range (the search bounds) and its nominal distribution on that range."""

    key: str
    """A dotted key as in a study's ``[grid]``: ``recipe.<recipe key>`` (e.g.
    ``recipe.layers.base.D_high``) or ``<table>.<field>`` of a settings table
    (``missions.length_m``, ``controller.cruise_speed_m_s``, ``vehicle.mass_kg``)."""
    low: float
    """Lower end of the range (in the key's unit)."""
    high: float
    """Upper end of the range (in the key's unit)."""
    nominal: str = "uniform"
    """Nominal distribution on the range: ``uniform``, or ``normal`` (mean, sd, truncated to the range)."""
    mean: float | None = None
    """Mean of the ``normal`` nominal (before truncation; default the middle of the range)."""
    sd: float | None = None
    """Standard deviation of the ``normal`` nominal (before truncation; default a sixth of the range)."""

    def __post_init__(self) -> None:
        if not isinstance(self.key, str) or "." not in self.key:
            raise InputError(f"SearchParam.key = {self.key!r}; must be a dotted key such as recipe.layers.base.D_high")
        target = self.key.split(".", 1)[0]
        if target not in ("recipe", *_SETTINGS_TARGETS):
            raise InputError(f"search key {self.key!r}: must start with recipe or one of {', '.join(_SETTINGS_TARGETS)}")
        if target != "recipe" and self.key.count(".") > 1:
            raise InputError(f"search key {self.key!r}: settings fields are one level deep ({target}.FIELD)")
        check_range(self, "low", self.low)
        check_range(self, "high", self.high, lo=self.low, lo_open=True)
        check_choice(self, "nominal", self.nominal, NOMINALS)
        if self.nominal == "normal":
            mean = (self.low + self.high) / 2 if self.mean is None else self.mean
            sd = (self.high - self.low) / 6 if self.sd is None else self.sd
            check_range(self, "mean", mean)
            check_range(self, "sd", sd, lo=0, lo_open=True)
            object.__setattr__(self, "mean", float(mean))
            object.__setattr__(self, "sd", float(sd))
        elif self.mean is not None or self.sd is not None:
            raise InputError(f"search key {self.key!r}: mean and sd are for nominal = \"normal\" only")

    # ------------------------------------------------------------------ the nominal CDF
    def _trunc(self) -> tuple[float, float]:
        """Standard-normal CDF values of the range ends of a ``normal`` nominal."""
        a = (self.low - self.mean) / self.sd
        b = (self.high - self.mean) / self.sd
        return float(special.ndtr(a)), float(special.ndtr(b))

    def cdf(self, x: np.ndarray) -> np.ndarray:
        """Nominal CDF F(x) on the range."""
        x = np.asarray(x, dtype=float)
        if self.nominal == "uniform":
            return np.clip((x - self.low) / (self.high - self.low), 0.0, 1.0)
        pa, pb = self._trunc()
        return np.clip((special.ndtr((x - self.mean) / self.sd) - pa) / (pb - pa), 0.0, 1.0)

    def pdf(self, x: np.ndarray) -> np.ndarray:
        """Nominal density on the range (0 outside it): 1 / (high - low), or the truncated normal's."""
        x = np.asarray(x, dtype=float)
        inside = (x >= self.low) & (x <= self.high)
        if self.nominal == "uniform":
            return np.where(inside, 1.0 / (self.high - self.low), 0.0)
        pa, pb = self._trunc()
        dens = np.exp(-0.5 * ((x - self.mean) / self.sd) ** 2) / (math.sqrt(2 * math.pi) * self.sd * (pb - pa))
        return np.where(inside, dens, 0.0)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`cdf`: the value at nominal probability ``u`` (clipped to the range)."""
        u = np.asarray(u, dtype=float)
        if self.nominal == "uniform":
            x = self.low + u * (self.high - self.low)
        else:
            pa, pb = self._trunc()
            x = self.mean + self.sd * special.ndtri(pa + u * (pb - pa))
        return np.clip(x, self.low, self.high)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """The value of standard-normal coordinate ``z``: F^-1(Phi(z))."""
        return self.ppf(special.ndtr(np.asarray(z, dtype=float)))

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """The standard-normal coordinate of value ``x``: Phi^-1(F(x)) (finite: F is kept in (1e-16, 1 - 1e-16))."""
        return special.ndtri(np.clip(self.cdf(x), 1e-16, 1 - 1e-16))

    def unit(self, x: np.ndarray) -> np.ndarray:
        """``x`` scaled to [0, 1] over the range (for distances between trials)."""
        return (np.asarray(x, dtype=float) - self.low) / (self.high - self.low)


@dataclass(frozen=True, kw_only=True)
class SearchConfig:
    """The ``[search]`` table: what a failure search runs and on which budget."""

    params: tuple[SearchParam, ...]
    """The searched keys (``[[search.params]]``), each with its range and nominal distribution."""
    methods: tuple[str, ...] = METHODS[:3]
    """What to run in every grid cell, one after another: ``falsify`` (the optimiser), ``random``
    (nominal sampling: plain Monte Carlo), ``ce-is`` (cross-entropy importance sampling) and
    ``uniform`` (uniform draws on the ranges: the naive search the falsifier is measured against)."""
    budget: int = 200
    """Trials per method and grid cell (``search run --budget`` overrides it, ``mc_budget`` and ``ce_budget`` too)."""
    mc_budget: int | None = None
    """Trials of the ``random`` stream (plain Monte Carlo) per grid cell, if not ``budget``: a large
    one is the Monte Carlo reference the other methods are measured against."""
    batch_size: int = 8
    """Trials proposed together (ask/tell); a batch runs in parallel on the executor."""
    sampler: str = "tpe"
    """The falsifier's optimiser: ``tpe`` (optuna's TPE, Bergstra et al. 2011) or ``cmaes``
    (CMA-ES, Hansen 2016, through the ``cmaes`` package; 2 or more parameters; its population is the batch)."""
    startup_trials: int = 16
    """TPE: trials drawn at random before the model is used."""
    objective: str = "margin"
    """What the falsifier minimises: ``margin`` (offroadbench.search.objective.failure_margin:
    negative on failure, the remaining distance; positive on success, the smaller of the tip and time margins)."""
    fix_terrain: bool = False
    """Drive every trial on terrain 0 of the study's seeds (else trial k of a method uses terrain k: random nuisance)."""
    fix_mission: bool = False
    """Drive every trial's mission 0 of its terrain (else mission k: random nuisance)."""
    distinct_distance: float = 0.1
    """Two failures are distinct when their parameters differ by at least this, in units of each
    range (largest difference over the parameters)."""
    local_step: float = 0.0
    """Falsifier: step of the local pattern search around failures, in units of each range (0: off,
    the optimiser alone). Once the stream has a failure (and ``startup_trials`` are done), all but
    ``explore_slots`` proposals of a batch are neighbours of its failures (one parameter moved by this
    step) on the failure's own terrain and mission (offroadbench.search.falsifier). At least ``distinct_distance``, so that a neighbour
    that fails is a distinct failure; TPE only."""
    local_terrain: str = "same"
    """Falsifier with ``local_step > 0``: where a local move drives: ``same`` (the failure's own
    terrain and mission: a move that fails shows a parameter that does not change the failure) or
    ``fresh`` (the stream's next nuisance draw, as the optimiser's proposals: a move that fails is a
    failure of the parameters, not of one terrain). With ``fresh`` a move is skipped when it is
    closer than ``distinct_distance`` to any point tried, on any terrain."""
    explore_slots: int = 2
    """Falsifier with ``local_step > 0``: proposals per batch still made by the optimiser on fresh terrains."""
    ce_stage_size: int = 50
    """Cross-entropy: trials per adaptive stage."""
    ce_quantile: float = 0.1
    """Cross-entropy: elite fraction rho; the stage's level is the rho-quantile of the margin (Rubinstein & Kroese 2004, Alg. 3.4.1)."""
    ce_max_stages: int = 6
    """Cross-entropy: adaptive stages at most before the final importance-sampling stage."""
    ce_defensive: float = 0.1
    """Cross-entropy: weight of the nominal density in the final defensive mixture (Hesterberg 1995); bounds every weight by 1/this."""
    ce_initial_sd: float = 1.0
    """Cross-entropy: standard deviation of the first adaptive stage's proposal N(0, sd^2 I), in
    standard-normal units (1: the nominal; 2 puts about a sixth of the draws beyond 2 nominal sd in
    each tail, where a failure region the margin does not point to can be found; its weights are
    at most sd^d)."""
    ce_min_failures: int = 0
    """Cross-entropy: once this many of the adaptive draws so far failed, the level is 0 outright
    and the proposal is fitted to the failures alone (0: off, the rho-quantile rule only). Where the
    margin of a passing trial says little about how near it came to failing, the rho-quantile's
    passing elites would pull the proposal back to the nominal's centre (their likelihood ratios
    are the largest); a few failures are a better guide."""
    ce_min_stages: int = 1
    """Cross-entropy: adaptive stages at least, even when a level reached 0 earlier (2: the second
    stage draws from the proposal fitted to the first's failures, and the fit pools both)."""
    ce_pool_weights: str = "own"
    """Cross-entropy: how the pooled draws of the adaptive stages are weighted in each fit: ``own``
    (each by the likelihood ratio of the proposal it came from) or ``mixture`` (each by the nominal
    over the mixture of the stages' proposals: the balance heuristic, Veach & Guibas 1995; Owen &
    Zhou 2000; offroadbench.search.estimators.mixture_log_weight). With a wide first stage
    (``ce_initial_sd`` > 1) ``mixture`` keeps its few heavy elites from fixing the proposal."""
    ce_budget: int | None = None
    """Trials of the ``ce-is`` stream per grid cell (adaptive stages included), if not ``budget``."""
    ce_min_sd: float = 1.0
    """Cross-entropy: smallest proposal standard deviation, in standard-normal units (1: never narrower
    than the nominal, so the likelihood ratio stays bounded on a half-space failure region and the
    interval keeps its coverage; smaller values adapt faster and risk heavy-tailed weights)."""
    level: float = 0.95
    """Confidence level of the P(failure) intervals."""
    replicate: int = 0
    """An independent repeat of the same search: another value draws every stream's proposals
    from other random numbers and, where the terrain or the mission is random nuisance, drives other
    terrains or missions; the domain (ranges, nominals, a fixed site) stays. 0: the original.
    How an estimator's or the falsifier's spread over repeats is measured
    (``benchmarks/bench_search.py --method ce-is``)."""

    def __post_init__(self) -> None:
        if not self.params:
            raise InputError("[search]: needs at least one [[search.params]] table")
        keys = [p.key for p in self.params]
        for k in keys:
            if keys.count(k) > 1:
                raise InputError(f"[search]: key {k!r} appears twice in [[search.params]]")
        if not self.methods:
            raise InputError(f"SearchConfig.methods is empty; allowed: {', '.join(METHODS)}")
        for m in self.methods:
            check_choice(self, "methods", m, METHODS)
        if len(set(self.methods)) != len(self.methods):
            raise InputError(f"SearchConfig.methods = {list(self.methods)} names a method twice")
        check_int(self, "budget", self.budget, lo=1)
        if self.mc_budget is not None:
            check_int(self, "mc_budget", self.mc_budget, lo=1)
        check_int(self, "batch_size", self.batch_size, lo=1, hi=10_000)
        check_choice(self, "sampler", self.sampler, SAMPLERS)
        if self.sampler == "cmaes" and len(self.params) < 2 and "falsify" in self.methods:
            raise InputError("SearchConfig.sampler = 'cmaes' needs 2 or more [[search.params]]; use 'tpe'")
        check_int(self, "startup_trials", self.startup_trials, lo=1)
        check_choice(self, "objective", self.objective, OBJECTIVES)
        for name in ("fix_terrain", "fix_mission"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"SearchConfig.{name} = {getattr(self, name)!r}; must be true or false")
        check_range(self, "distinct_distance", self.distinct_distance, lo=0, hi=1, lo_open=True)
        check_range(self, "local_step", self.local_step, lo=0, hi=1)
        if 0 < self.local_step < self.distinct_distance:
            raise InputError(f"SearchConfig.local_step = {self.local_step!r}; must be 0 (off) or at least "
                             f"distinct_distance = {self.distinct_distance!r}")
        if self.local_step > 0 and self.sampler != "tpe":
            raise InputError(f"SearchConfig.local_step = {self.local_step!r} needs sampler = 'tpe' (got {self.sampler!r})")
        check_int(self, "explore_slots", self.explore_slots, lo=0)
        check_choice(self, "local_terrain", self.local_terrain, LOCAL_TERRAINS)
        check_int(self, "ce_stage_size", self.ce_stage_size, lo=10)
        check_range(self, "ce_quantile", self.ce_quantile, lo=0, hi=0.5, lo_open=True)
        check_int(self, "ce_max_stages", self.ce_max_stages, lo=1, hi=50)
        check_range(self, "ce_defensive", self.ce_defensive, lo=0, hi=1, lo_open=True, hi_open=True)
        check_range(self, "ce_min_sd", self.ce_min_sd, lo=0, lo_open=True)
        check_range(self, "ce_initial_sd", self.ce_initial_sd, lo=0.5, hi=4)
        check_int(self, "ce_min_failures", self.ce_min_failures, lo=0)
        check_int(self, "ce_min_stages", self.ce_min_stages, lo=1, hi=self.ce_max_stages)
        check_choice(self, "ce_pool_weights", self.ce_pool_weights, POOL_WEIGHTS)
        if self.ce_budget is not None:
            check_int(self, "ce_budget", self.ce_budget, lo=1)
        check_range(self, "level", self.level, lo=0, hi=1, lo_open=True, hi_open=True)
        check_int(self, "replicate", self.replicate, lo=0, hi=(1 << 20) - 1)

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(p.key for p in self.params)

    @property
    def dim(self) -> int:
        return len(self.params)

    def method_budget(self, method: str, budget: int | None = None) -> int:
        """Trials of ``method`` per grid cell. ``budget`` (``search run --budget``) caps every
        method alike; without it, ``mc_budget`` for ``random`` and ``ce_budget`` for ``ce-is`` where
        set, else the table's ``budget``."""
        if budget is not None:
            return budget
        if method == "random" and self.mc_budget is not None:
            return self.mc_budget
        if method == "ce-is" and self.ce_budget is not None:
            return self.ce_budget
        return self.budget

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Parameter values (n, d) of standard-normal coordinates ``z`` (n, d)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        return np.column_stack([p.from_z(z[:, i]) for i, p in enumerate(self.params)])

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Standard-normal coordinates (n, d) of parameter values ``x`` (n, d)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return np.column_stack([p.to_z(x[:, i]) for i, p in enumerate(self.params)])

    def unit(self, x: np.ndarray) -> np.ndarray:
        """Parameter values (n, d) scaled to [0, 1] over each range."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return np.column_stack([p.unit(x[:, i]) for i, p in enumerate(self.params)])

    def values(self, x: np.ndarray) -> dict[str, float]:
        """{key: value} of one point (a row of ``x``), as plain floats."""
        return {k: float(v) for k, v in zip(self.keys, np.asarray(x, dtype=float).ravel(), strict=True)}


_PARAM_KEYS = tuple(f.name for f in dataclasses.fields(SearchParam))


def search_from_dict(table: Mapping[str, Any], where: str = "[search]") -> SearchConfig:
    """The SearchConfig of a ``[search]`` TOML table (with its ``params`` array of tables);
    unknown keys are InputErrors naming the known ones."""
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table")
    data = dict(table)
    known = [f.name for f in dataclasses.fields(SearchConfig)]
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: {', '.join(known)}")
    raw = data.pop("params", None)
    if not isinstance(raw, list) or not all(isinstance(p, Mapping) for p in raw):
        raise InputError(f"{where}: needs [[search.params]] tables (key, low, high, nominal)")
    params = []
    for i, p in enumerate(raw):
        bad = sorted(set(p) - set(_PARAM_KEYS))
        if bad:
            raise InputError(f"{where} params[{i}]: unknown key(s) {', '.join(bad)}; known keys: {', '.join(_PARAM_KEYS)}")
        try:
            params.append(SearchParam(**{k: (float(v) if k in ("low", "high", "mean", "sd") and _is_number(v) else v)
                                         for k, v in p.items()}))
        except TypeError as exc:
            raise InputError(f"{where} params[{i}]: {exc}") from None
        except InputError as exc:
            raise InputError(f"{where} params[{i}]: {exc}") from None
    if "methods" in data:
        if not isinstance(data["methods"], list):
            raise InputError(f"{where}: methods must be a list, e.g. [\"falsify\", \"random\"]")
        data["methods"] = tuple(data["methods"])
    for k in ("distinct_distance", "local_step", "ce_quantile", "ce_defensive", "ce_min_sd", "ce_initial_sd", "level"):
        if k in data and _is_number(data[k]):
            data[k] = float(data[k])
    try:
        return SearchConfig(params=tuple(params), **data)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))

