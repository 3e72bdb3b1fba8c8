"""Failure search: a falsifier that drives the study pipeline toward failures, and estimates of
P(failure) under a nominal distribution of conditions (plain Monte Carlo and cross-entropy
importance sampling).

Typical use::

    from offroadbench.search import load_search, run_search, search_report
    plan = load_search("experiments/failure-search.toml")
    run_search(plan, "runs/failure-search", budget=64, workers=2)
    search_report("runs/failure-search")        # tables, figures, worst failures to replay

A search's trials are study trials (same pipeline, executors and store): see
offroadbench.search.runner. The search space is the ``[search]`` table (offroadbench.search.space).
"""

from offroadbench.search.plan import SearchPlan, load_search, search_from_data
from offroadbench.search.runner import SearchSummary, run_search
from offroadbench.search.space import SearchConfig, SearchParam

__all__ = ["SearchConfig", "SearchParam", "SearchPlan", "SearchSummary", "load_search", "search_from_data",
           "run_search"]
