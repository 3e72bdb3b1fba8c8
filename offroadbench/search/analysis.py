"""A search study's analysis plan (``[analysis]``): what its claims are about, fixed before the run.

A study's ``[analysis]`` (offroadbench.study.stats.plan) names confirmatory tests between grid cells; a
search's names the estimand, the estimator and interval its P(failure) claim rests on, the
reference that estimate is judged against, the baseline the falsifier is judged against and by
which count, and the stopping rule. The table is part of the search file, so it is stored with the
run (the stored study TOML) and enters the search's id: a run whose plan was changed after trials
were stored is refused like a changed search (offroadbench.search.plan.SearchPlan.search_id). The
report (offroadbench.search.report) prints the plan above the figures it names (the modes, the
falsifier against both baselines, the estimates at the reference with both intervals; the plan
says which of them the claims rest on) and calls every other number exploratory. TOML::

    [analysis]
    estimand = "P(failure) of each planner under the nominal distribution of friction and speed"
    estimator = "ce-is"              # ce-is (cross-entropy importance sampling) | mc (plain Monte Carlo)
    interval = "bootstrap-t"         # ce-is: bootstrap-t (studentized, over the final draws) | normal
    reference = "boundary"           # boundary: a measured boundary in one parameter | mc: the random stream
    boundary_param = "sim.terrain_friction"   # reference = "boundary": the parameter (failure below)
    reference_from = "experiments/results/failure-search-site"   # optional: the boundary measured there
    baseline = "uniform"             # the falsifier's baseline: uniform (its own search box) | random (nominal)
    first_k = [1, 10]                # trials to the k-th failure: the falsifier's counts
    stopping = "budget"              # each method stops at its trial budget ([search] budget, mc_budget, ce_budget)
    gain = "work-normalised"         # the IS gain: p (1 - p) / (N_IS V_IS) at the reference p

Only rules the code carries out are accepted (an unknown value is an InputError naming the allowed
ones); ``stopping = "budget"`` is the only stopping rule a search has (no sequential stopping).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping

from offroadbench.config import check_choice
from offroadbench.errors import InputError

__all__ = ["SearchAnalysis", "analysis_from_dict", "ESTIMATORS", "INTERVALS", "REFERENCES", "BASELINES", "STOPPING",
           "GAINS"]

ESTIMATORS = ("ce-is", "mc")
INTERVALS = ("bootstrap-t", "normal")
REFERENCES = ("boundary", "mc")
BASELINES = ("uniform", "random")
STOPPING = ("budget",)
GAINS = ("work-normalised",)


@dataclass(frozen=True, kw_only=True)
class SearchAnalysis:
    """The ``[analysis]`` table of a search file (module docstring)."""

    estimand: str
    """The quantity claimed, in words (printed in the report)."""
    estimator: str = "ce-is"
    """Which estimate of P(failure) the claim rests on: ``ce-is`` or ``mc``."""
    interval: str = "bootstrap-t"
    """The interval of a ``ce-is`` estimate: ``bootstrap-t`` (offroadbench.search.estimators.
    bootstrap_t_interval) or ``normal``; a ``mc`` estimate always has Clopper-Pearson's."""
    reference: str = "mc"
    """How the reference P is obtained: ``mc`` (the run's ``random`` stream) or ``boundary`` (the
    measured boundary in ``boundary_param`` over every finished trial of the group;
    offroadbench.search.baselines.MeasuredBoundary)."""
    boundary_param: str | None = None
    """``reference = "boundary"``: the searched key failure is a function of (failing below the boundary)."""
    reference_from: str | None = None
    """``reference = "boundary"``: a committed results folder of the same site and route (its
    ``search.toml``, ``trials.csv`` and ``repeats.csv``; a path relative to the repository root)
    whose trials of the same planner measure the boundary, instead of the run's own. The reference
    is then independent of the estimates it judges (the run's trials only check the boundary); the
    nominal it is integrated against is this search's (offroadbench.search.evaluate.folder_reference)."""
    baseline: str = "uniform"
    """What the falsifier's trials to the k-th failure are measured against: ``uniform`` draws on
    its own search box (the ``uniform`` stream, or streams computed from the boundary where the run
    has none) or ``random`` (nominal) draws."""
    first_k: tuple[int, ...] = (1, 10)
    """The k of the falsifier's counts (trials to the k-th failure; the report adds the k-th distinct failure)."""
    stopping: str = "budget"
    """The stopping rule: ``budget`` (every method runs its fixed trial budget)."""
    gain: str = "work-normalised"
    """The importance-sampling gain: the work-normalised variance ratio at the reference p."""
    level: float = 0.95
    """Confidence level of every interval the plan names."""

    def __post_init__(self) -> None:
        if not isinstance(self.estimand, str) or not self.estimand.strip():
            raise InputError("[analysis] estimand: say in words what P(failure) is of (a non-empty string)")
        check_choice(self, "estimator", self.estimator, ESTIMATORS)
        check_choice(self, "interval", self.interval, INTERVALS)
        check_choice(self, "reference", self.reference, REFERENCES)
        check_choice(self, "baseline", self.baseline, BASELINES)
        check_choice(self, "stopping", self.stopping, STOPPING)
        check_choice(self, "gain", self.gain, GAINS)
        if self.reference == "boundary" and not self.boundary_param:
            raise InputError('[analysis] reference = "boundary" needs boundary_param (the searched key failure falls with)')
        if self.reference != "boundary" and self.boundary_param is not None:
            raise InputError('[analysis] boundary_param is for reference = "boundary" only')
        if self.reference_from is not None and (self.reference != "boundary" or not isinstance(self.reference_from, str)
                                                or not self.reference_from.strip()):
            raise InputError(f'[analysis] reference_from = {self.reference_from!r}: a results folder (a path), '
                             'for reference = "boundary" only')
        ks = self.first_k
        if (not isinstance(ks, tuple) or not ks
                or not all(isinstance(k, int) and not isinstance(k, bool) and k >= 1 for k in ks)):
            raise InputError(f"[analysis] first_k = {list(ks) if isinstance(ks, tuple) else ks!r}; must be a list of integers >= 1")
        if not (isinstance(self.level, float) and 0 < self.level < 1):
            raise InputError(f"[analysis] level = {self.level!r}; must be in (0, 1)")


def analysis_from_dict(table: Mapping[str, Any] | None, keys: tuple[str, ...], where: str = "[analysis]") -> SearchAnalysis | None:
    """The SearchAnalysis of an ``[analysis]`` table (None when absent); ``keys`` are the search's
    searched keys (``boundary_param`` must be one)."""
    if table is None:
        return None
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table")
    data = dict(table)
    known = [f.name for f in dataclasses.fields(SearchAnalysis)]
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: {', '.join(known)}")
    if "first_k" in data:
        if not isinstance(data["first_k"], list):
            raise InputError(f"{where}: first_k must be a list, e.g. [1, 10]")
        data["first_k"] = tuple(data["first_k"])
    if "level" in data and isinstance(data["level"], int) and not isinstance(data["level"], bool):
        data["level"] = float(data["level"])
    if "estimand" not in data:
        raise InputError(f"{where}: needs estimand (what P(failure) is of, in words)")
    try:
        plan = SearchAnalysis(**data)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    if plan.boundary_param is not None and plan.boundary_param not in keys:
        raise InputError(f"{where}: boundary_param = {plan.boundary_param!r} is not a searched key ({', '.join(keys)})")
    return plan
