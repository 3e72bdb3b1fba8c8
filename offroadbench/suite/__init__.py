"""Versioned task suites and their score cards (``offroadbench suite``; issue 46).

A suite (``suites/<name>.toml``, e.g. ``offroadbench-v1``) fixes terrains, missions, vehicle,
sensor and rules in tiers (``quick``, ``full``); each of its categories is one study run through
the study pipeline. A run chooses only the planner and ends in a score card: success, time, ride
and failure modes per category with terrain-level intervals, a BARN-style bounded task score
aggregated as an interquartile mean with a stratified bootstrap interval and a performance
profile, and paired comparisons with the shipped baselines' committed cards.

Typical use::

    from offroadbench.suite import load_suite, plan_suite, run_suite, score_run
    suite, path = load_suite("offroadbench-v1")
    planned = plan_suite(suite, "quick", "astar")
    run_suite(planned, "runs/suite/astar", workers=2)
    card = score_run(suite, str(path), "quick", "astar", "runs/suite/astar")
"""

from offroadbench.suite.cards import read_card, shipped_cards, write_card
from offroadbench.suite.run import CategoryPlan, plan_suite, run_suite, score_run, suite_trials
from offroadbench.suite.score import compare, make_card, summarise
from offroadbench.suite.spec import CategoryConfig, SuiteConfig, TierConfig, load_suite, tasks_sha256

__all__ = [
    "CategoryConfig",
    "CategoryPlan",
    "SuiteConfig",
    "TierConfig",
    "compare",
    "load_suite",
    "make_card",
    "plan_suite",
    "read_card",
    "run_suite",
    "score_run",
    "shipped_cards",
    "suite_trials",
    "summarise",
    "tasks_sha256",
    "write_card",
]
