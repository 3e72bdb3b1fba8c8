"""A reference measured on another results folder's trials (``[analysis] reference_from``,
offroadbench.search.evaluate.folder_reference): the same boundary as the folder's own reference,
integrated against the searching study's nominal; its bootstrap interval and the check of other
trials against it."""

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from offroadbench.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SITE = ROOT / "experiments" / "results" / "failure-search-site"


def test_the_site_folder_as_its_own_reference_is_its_pooled_reference():
    from offroadbench.search import evaluate as ev
    from offroadbench.search import load_search

    cfg = load_search(SITE / "search.toml").search
    site = load_search(ROOT / "experiments" / "failure-search-site.toml").analysis
    run, rep = pd.read_csv(SITE / "trials.csv"), pd.read_csv(SITE / "repeats.csv")
    for group, planner in ((0, "astar"), (1, "straight")):
        own = ev.pooled_reference(run, rep, cfg, site, group, planner)
        via = ev.folder_reference(SITE, planner, cfg, dataclasses.replace(
            site, reference_from="experiments/results/failure-search-site"))
        assert via.p == pytest.approx(own.p, rel=1e-12) and (via.low, via.high) == pytest.approx((own.low, own.high))
        assert via.boundary.trials == own.boundary.trials


def test_the_rare_study_integrates_the_site_boundary_against_its_own_nominal():
    from offroadbench.search import evaluate as ev
    from offroadbench.search import load_search

    plan = load_search(ROOT / "experiments" / "failure-search-rare.toml")
    ref = ev.reference(pd.DataFrame({"done": [], "failed": []}), plan.search, plan.analysis, "astar", ROOT)
    b, param = ref.boundary, plan.search.params[0]
    # P = F(low) + the band's isotonic rate times the nominal mass of each step, F the rare nominal's CDF
    edges = np.concatenate([[b.low], b.band_u[1:], [b.high]])
    assert ref.p == pytest.approx(param.cdf(np.array([b.low]))[0] + np.sum(b.band_p * np.diff(param.cdf(edges))))
    assert ref.low <= ref.p <= ref.high <= 1e-3  # the study's rule: the whole bracket at most 1e-3
    # the same boundary at the site's nominal is the site's reference: only the nominal differs
    site_cfg = load_search(SITE / "search.toml").search
    assert b.probability(site_cfg.params[0]) == pytest.approx(0.0223, abs=5e-5)


def test_a_folder_that_is_not_a_results_folder_is_refused(tmp_path):
    from offroadbench.search import evaluate as ev

    with pytest.raises(InputError, match="not a search results folder"):
        ev.folder_trials(tmp_path, "astar")
    with pytest.raises(InputError, match="no finished trial of planner"):
        ev.folder_trials(SITE, "mppi")


def test_the_check_counts_the_trials_the_boundary_did_not_predict():
    from offroadbench.search.baselines import measured_boundary
    from offroadbench.search.evaluate import boundary_check

    b = measured_boundary(np.array([0.1, 0.15, 0.2, 0.22, 0.25, 0.3]), np.array([1, 1, 0, 1, 0, 0], bool))
    c = boundary_check(b, np.array([0.12, 0.14, 0.21, 0.26, 0.5]), np.array([1, 0, 1, 1, 0], bool))
    assert (c["low"], c["high"]) == (0.2, 0.22)
    assert c == {**c, "trials": 5, "certain": 2, "certain passed": 1, "safe": 2, "safe failed": 1, "band": 1,
                 "band failed": 1}


def test_the_reference_interval_holds_the_reference_and_narrows_with_more_trials():
    from offroadbench.search.baselines import measured_boundary
    from offroadbench.search.evaluate import reference_interval
    from offroadbench.search.space import SearchParam

    param = SearchParam(key="sim.terrain_friction", low=0.1, high=1.0, nominal="normal", mean=0.6, sd=0.12)
    rng = np.random.default_rng(3)
    widths = []
    for n in (300, 3000):
        u = rng.uniform(0.1, 0.4, n)
        f = rng.random(n) < np.clip((0.23 - u) / 0.04, 0, 1)  # certain below 0.19, none above 0.23
        p = measured_boundary(u, f).probability(param)
        lo, hi = reference_interval(u, f, param, n_boot=300)
        assert lo <= p <= hi
        widths.append(hi - lo)
    assert widths[1] < widths[0]
