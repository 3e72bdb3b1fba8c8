"""The estimators and the CMA-ES falsifier through the whole search pipeline (store, executor,
report), on a stand-in trial whose failure probability is known exactly: it fails when the
searched cruise speed exceeds a threshold, whatever the terrain."""

import copy
import math
import sqlite3

import numpy as np
import pytest
from scipy import special

from offroadbench.search import run_search, search_from_data
from offroadbench.search.objective import failure_margin
from offroadbench.search.report import build_search_report, estimates, search_table
from tests.search.stand_in import SEARCH, stand_in_trials

THRESHOLD = 1.75  # m/s
MEAN, SD, LOW, HIGH = 1.0, 0.3, 0.5, 2.0


def speed_trials(prepared, settings):
    speed = settings.controller.cruise_speed_m_s
    for row in stand_in_trials(prepared, settings):
        ok = speed < THRESHOLD
        row.update(success=ok, failure_reason="" if ok else "tipped", final_distance_to_goal_m=0.0 if ok else 1.0,
                   traversal_time_s=3.0 / speed if ok else float("nan"),
                   max_abs_roll_deg=70.0 * speed / THRESHOLD if ok else 80.0)
        yield row


def truth() -> float:
    """P(speed > THRESHOLD) for speed ~ N(MEAN, SD) truncated to [LOW, HIGH]."""
    a, b, t = ((v - MEAN) / SD for v in (LOW, HIGH, THRESHOLD))
    return float((special.ndtr(b) - special.ndtr(t)) / (special.ndtr(b) - special.ndtr(a)))


def _search(**changes):
    data = copy.deepcopy(SEARCH)
    data["search"].update(changes)
    return search_from_data(data)


@pytest.fixture(scope="module")
def estimated(tmp_path_factory):
    out = tmp_path_factory.mktemp("estimates")
    plan = _search(methods=["random", "ce-is"], budget=150, batch_size=25, ce_stage_size=25)
    run_search(plan, out, executor="inline", trial_fn=speed_trials)
    df, _ = search_table(out)
    return plan, out, df


def test_the_pipeline_estimates_a_known_failure_probability(estimated):
    plan, out, df = estimated
    p = truth()
    assert 0.005 < p < 0.02
    ests = estimates(df, plan.search)
    mc, ce = ests[(0, "mc")], ests[(0, "ce-is")]
    assert mc.p == pytest.approx(df[df["method"] == "random"]["failed"].mean())
    assert ce.trials == 150 and ce.failures >= 10  # the proposal moved to the failures
    assert ce.covers(p), (ce, p)
    assert ce.rel_error < 0.35
    # the stored likelihood ratios are those of the nominal against the proposal: nominal draws have 0
    assert np.allclose(df[df["method"] == "random"]["log_w"], 0.0)
    assert (df[df["stage"] == "ce-final"]["log_w"] < 0).mean() > 0.5  # failures are overweighted by the proposal


def test_the_report_of_a_search_holds_its_tables(estimated):
    _, out, _ = estimated
    rep = build_search_report(out)
    assert {"trials.csv", "streams.csv", "estimates.csv", "is_gain_bounds.csv"} <= set(rep.tables)
    assert "failures_vs_trials.png" in rep.figures
    est = rep.tables["estimates.csv"]
    assert set(est["estimator"]) == {"mc", "ce-is"}
    assert "## P(failure) under the nominal distribution" in rep.markdown


def test_the_cmaes_falsifier_finds_the_failures_and_resumes_identically(tmp_path):
    plan = _search(methods=["falsify"], sampler="cmaes", budget=24, batch_size=6)
    run_search(plan, tmp_path / "a", executor="inline", trial_fn=speed_trials)
    count = {"n": 0}

    def interrupted(prepared, settings):
        for row in speed_trials(prepared, settings):
            count["n"] += 1
            if count["n"] > 14:
                raise KeyboardInterrupt
            yield row

    with pytest.raises(KeyboardInterrupt):
        run_search(plan, tmp_path / "b", executor="inline", trial_fn=interrupted)
    run_search(plan, tmp_path / "b", executor="inline", trial_fn=speed_trials)

    def table(d):
        con = sqlite3.connect(d / "study.sqlite")
        try:
            return con.execute("SELECT s.cell, s.x, t.row FROM search_trials s JOIN trials t USING (cell) ORDER BY cell").fetchall()
        finally:
            con.close()

    assert table(tmp_path / "a") == table(tmp_path / "b")
    df, _ = search_table(tmp_path / "a")
    first, last = df[df["batch"] == 0], df[df["batch"] == df["batch"].max()]
    assert last["controller.cruise_speed_m_s"].mean() > first["controller.cruise_speed_m_s"].mean()
    assert df["failed"].sum() >= 3


@pytest.mark.parametrize("row, sign", [
    ({"success": False, "final_distance_to_goal_m": 3.0}, -1),
    ({"success": True, "final_distance_to_goal_m": 0.2}, 1),
])
def test_the_margin_is_negative_exactly_on_failure(row, sign):
    base = {"start_x_m": 0.0, "start_y_m": 0.0, "goal_x_m": 6.0, "goal_y_m": 0.0, "max_abs_roll_deg": 30.0,
            "max_abs_pitch_deg": 10.0, "traversal_time_s": 9.0}
    m = failure_margin({**base, **row}, tip_angle_deg=75.0, timeout_factor=3.0, speed_m_s=1.0)
    assert math.copysign(1, m) == sign
    if sign < 0:
        assert m == pytest.approx(-0.5)  # half the mission left
    else:
        assert m == pytest.approx(min(1 - 30 / 75, 1 - 9.0 / 18.0))  # tip 0.6, time 0.5


def test_the_uniform_stream_draws_the_search_box_with_the_nominal_over_uniform_weights(tmp_path):
    """The naive search (method ``uniform``): draws spread over the whole range (not the nominal's
    centre), and stored log likelihood ratios log(nominal / uniform) that make its trials an unbiased
    importance-sampling estimate of P too (checked against the known P within its error)."""
    plan = _search(methods=["uniform"], budget=400, batch_size=50)
    run_search(plan, tmp_path, executor="inline", trial_fn=speed_trials)
    df, _ = search_table(tmp_path)
    speed = df["controller.cruise_speed_m_s"].to_numpy()
    assert len(df) == 400 and set(df["stage"]) == {"uniform"}
    # uniform on [0.5, 2.0]: a quarter of the draws above 1.625 (the nominal puts 2 % there)
    assert abs(np.mean(speed > 1.625) - 0.25) < 4 * np.sqrt(0.25 * 0.75 / 400)
    p_param = plan.search.params[0]
    expect = np.log(p_param.pdf(speed) * (p_param.high - p_param.low))
    d_high = plan.search.params[1]  # uniform nominal: weight 1
    assert np.allclose(df["log_w"], expect + np.log(d_high.pdf(df[d_high.key].to_numpy()) * (d_high.high - d_high.low)))
    y = np.where(df["failed"], np.exp(df["log_w"]), 0.0)
    assert abs(y.mean() - truth()) < 4 * y.std(ddof=1) / np.sqrt(len(y))
    assert df["failed"].mean() > 5 * truth()  # the box finds failures far more often than the nominal
