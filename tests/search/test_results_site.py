"""experiments/results/failure-search-site/README.md: the figures issue 45 asks for (failure modes,
the falsifier against uniform and nominal sampling, importance sampling's gain at a common p and
its intervals' coverage over the repeats), recomputed from the committed trials.csv and repeats.csv
through offroadbench.search.evaluate with the study file's [analysis] plan, and the tables the
folder commits (is_repeats.csv, falsifier_baselines.csv, ...) recomputed too."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "experiments" / "results" / "failure-search-site"
STUDY = ROOT / "experiments" / "failure-search-site.toml"
_NUM = r"(-?\d+(?:\.\d+)?|inf)"


@pytest.fixture(scope="module")
def figures():
    from offroadbench.search import evaluate as ev
    from offroadbench.search import load_search

    cfg = load_search(FOLDER / "search.toml").search
    analysis = load_search(STUDY).analysis
    run = pd.read_csv(FOLDER / "trials.csv")
    repeats = pd.read_csv(FOLDER / "repeats.csv")
    out = {p: ev.results_figures(run, repeats, cfg, analysis, g, p) for g, p in ((0, "astar"), (1, "straight"))}
    for p, g in (("astar", 0), ("straight", 1)):
        out[p]["mc"] = ev.mc_position(run[run["group"] == g], cfg, out[p]["reference"])
    return out


def _readme() -> str:
    """The README with every run of whitespace one space (its lines are wrapped)."""
    return " ".join((FOLDER / "README.md").read_text().split())


def _check(pattern: str, computed: list[float]) -> None:
    hit = re.search(pattern, _readme())
    assert hit, f"README no longer states {pattern[:80]!r}: re-point the sample"
    stated = hit.groups()
    assert len(stated) == len(computed)
    for text, value in zip(stated, computed, strict=True):
        if text is None or text == "inf":  # None: a one-sided bound (\u2265 x) states no upper end
            assert value == np.inf, f"README says inf, the tables give {value:.6g} ({pattern[:60]})"
            continue
        half = 0.5 * 10.0 ** -(len(text.split(".")[1]) if "." in text else 0)
        assert abs(float(text) - value) <= half + 1e-9, f"README says {text}, the tables give {value:.6g} ({pattern[:60]})"


def test_the_reference_and_where_monte_carlo_sits(figures):
    out = []
    for p in ("astar", "straight"):
        ref = figures[p]["reference"]
        b = ref.boundary
        out += [ref.p, ref.low, ref.high, b.low, b.high, b.band_failed, b.band_trials, b.trials]
    mc = figures["astar"]["mc"]
    out += [mc["estimate"].p, mc["below"], mc["expected_below"]]
    _check(rf"A\*: \*\*{_NUM}\*\* \(bracket {_NUM}-{_NUM}; failure below {_NUM} and none above {_NUM}, {_NUM} of "
           rf"the {_NUM} trials between failed, over {_NUM} trials\); the line: \*\*{_NUM}\*\* \(bracket {_NUM}-{_NUM}; "
           rf"below {_NUM}, above {_NUM}, {_NUM} of {_NUM}, over {_NUM} trials\)[\s\S]*?Monte Carlo's {_NUM}[^:]*: "
           rf"{_NUM} of its 1600 draws fell below that friction where the nominal puts {_NUM}", out)


def test_the_failure_modes_and_the_sensitivity(figures):
    a, s = figures["astar"], figures["straight"]
    sa = {x.key: x for x in a["sensitivity"]}
    ss = {x.key: x for x in s["sensitivity"]}
    f, v = "sim.terrain_friction", "controller.cruise_speed_m_s"
    assert sa[f].active and not sa[v].active and ss[f].active and not ss[v].active
    _check(rf"\*\*{_NUM} failure mode\*\* for A\* and \*\*{_NUM}\*\* for the line", [len(a["modes"]), len(s["modes"])])
    _check(rf"eta\^2 {_NUM} for the friction against a threshold of {_NUM}, {_NUM} for the cruise speed against "
           rf"{_NUM} \(A\*; the line: {_NUM} against {_NUM}, {_NUM} against {_NUM}\)",
           [sa[f].eta2, sa[f].threshold, sa[v].eta2, sa[v].threshold, ss[f].eta2, ss[f].threshold, ss[v].eta2,
            ss[v].threshold])
    m = a["modes"].iloc[0]
    lo, hi = (float(x) for x in m["sim.terrain_friction range"].split("-"))
    _check(rf"A\*'s mode: {_NUM} failures at a friction of {_NUM}-{_NUM}", [m["failures"], lo, hi])


def _baseline_row(fig: dict, count: str) -> list[float]:
    r = fig["baselines"].set_index("count").loc[count]
    return [r["falsifier streams"], r["falsifier median"], r["falsifier low"], r["falsifier high"],
            r["uniform, real streams: median"], r["uniform, real streams: ratio"], r["uniform, real streams: ratio low"],
            r["uniform, real streams: ratio high"],
            r["uniform, computed: median"], r["uniform, computed: ratio"], r["uniform, computed: ratio low"],
            r["uniform, computed: ratio high"],
            r["nominal, computed: median"], r["nominal, computed: ratio"], r["nominal, computed: ratio low"],
            r["nominal, computed: ratio high"],
            r["nominal, orders of the Monte Carlo pool: median"], r["nominal, orders of the Monte Carlo pool: ratio"]]


@pytest.mark.parametrize("count", ["1-th failure", "10-th failure", "10-th distinct failure"])
def test_the_falsifier_against_uniform_and_nominal_sampling(figures, count):
    label = {"1-th failure": "first failure", "10-th failure": "10th failure",
             "10-th distinct failure": "10th distinct failure"}[count]
    cell = rf"{_NUM} \({_NUM}-{_NUM}\)"
    _check(rf"\| {label} \| {_NUM} \| \*\*{cell}\*\* \| {_NUM}: \*\*{_NUM}x\*\* \((?:≥ )?{_NUM}(?:-{_NUM})?\) \| {_NUM}: "
           rf"\*\*{_NUM}x\*\* \({_NUM}-{_NUM}\) \| {_NUM}: {_NUM}x \({_NUM}-{_NUM}\) \| {_NUM}: {_NUM}x \|",
           _baseline_row(figures["astar"], count))


def test_importance_sampling_over_the_repeats(figures):
    s = figures["astar"]["is_summary"]
    assert s["runs"] >= 20
    _check(rf"Over the \*\*{_NUM}\*\* A\* runs the estimates average {_NUM} and spread by {_NUM} % of the reference; "
           rf"the gain by that spread is \*\*{_NUM}x\*\* \(95 % bootstrap interval {_NUM}-{_NUM}x\), by each run's stated "
           rf"error a median {_NUM}x\. The bootstrap-t intervals hold the reference in \*\*{_NUM} of {_NUM}\*\*, the "
           rf"normal ones in {_NUM} of {_NUM}",
           [s["runs"], s["mean P"], 100 * s["rel. RMSE"], s["gain"], s["gain low"], s["gain high"],
            s["median stated gain"], s["bootstrap-t holds"], s["runs"], s["normal holds"], s["runs"]])
    assert s["bootstrap-t holds"] >= 0.9 * s["runs"]


@pytest.mark.parametrize("name, key", [("is_repeats.csv", "is"), ("falsifier_baselines.csv", "baselines"),
                                       ("falsifier_streams.csv", "falsifier"), ("uniform_streams.csv", "uniform"),
                                       ("modes.csv", "modes")])
def test_the_committed_tables_recompute(figures, name, key):
    table = pd.read_csv(FOLDER / name)
    for p in ("astar", "straight"):
        if key not in figures[p] or not len(figures[p][key]):
            continue
        want = figures[p][key].reset_index(drop=True)
        got = table[table["planner"] == p].drop(columns="planner").reset_index(drop=True)
        extra = [c for c in got.columns if c not in want.columns]  # another planner's columns
        assert got[extra].isna().all().all(), (name, extra)
        got = got[[c for c in got.columns if c in want.columns]]
        assert list(got.columns) == list(want.columns)
        for c in want.columns:
            if pd.api.types.is_numeric_dtype(want[c]) and want[c].dtype != bool:
                assert np.allclose(got[c].to_numpy(float), want[c].to_numpy(float), rtol=1e-9, equal_nan=True), (name, c)
            else:
                assert got[c].astype(str).tolist() == want[c].astype(str).tolist(), (name, c)


def test_the_headline(figures):
    b = figures["astar"]["baselines"].set_index("count")
    first, tenth, distinct = (b.loc[c] for c in ("1-th failure", "10-th failure", "10-th distinct failure"))
    u, n = "uniform, computed: ", "nominal, computed: "
    s = figures["astar"]["is_summary"]
    _check(rf"the first failure in a median of {_NUM} trials against uniform sampling's {_NUM} \(\*\*no gain\*\*: "
           rf"{_NUM}x, interval {_NUM}-{_NUM}x\); the 10th failure in {_NUM} against {_NUM} \(\*\*{_NUM}x\*\*, "
           rf"{_NUM}-{_NUM}x\); the study's \"10 distinct\" in {_NUM} against {_NUM} \(\*\*{_NUM}x\*\*, {_NUM}-{_NUM}x\); "
           rf"the {_NUM} real uniform streams agree \({_NUM}x and {_NUM}x\)\. Against nominal sampling \(whose job is "
           rf"estimating P, not finding failures\) {_NUM}x, {_NUM}x and {_NUM}x",
           [first["falsifier median"], first[u + "median"], first[u + "ratio"], first[u + "ratio low"],
            first[u + "ratio high"], tenth["falsifier median"], tenth[u + "median"], tenth[u + "ratio"],
            tenth[u + "ratio low"], tenth[u + "ratio high"], distinct["falsifier median"], distinct[u + "median"],
            distinct[u + "ratio"], distinct[u + "ratio low"], distinct[u + "ratio high"],
            tenth["uniform, real streams: streams"], tenth["uniform, real streams: ratio"],
            distinct["uniform, real streams: ratio"], first[n + "ratio"], tenth[n + "ratio"], distinct[n + "ratio"]])
    assert first[u + "ratio"] < 1 < tenth[u + "ratio"]  # "no gain" on the first failure, a gain on the 10th
    _check(rf"reference {_NUM}\): over {_NUM} A\* runs of 200 trials the work-normalised gain is \*\*{_NUM}x\*\* by "
           rf"the spread of the estimates \(95 % bootstrap interval {_NUM}-{_NUM}x; a median {_NUM}x by each run's "
           rf"stated error\), and the bootstrap-t intervals hold the reference in \*\*{_NUM} of {_NUM}\*\* runs \(the "
           rf"normal ones in {_NUM} of {_NUM}\)",
           [figures["astar"]["reference"].p, s["runs"], s["gain"], s["gain low"], s["gain high"],
            s["median stated gain"], s["bootstrap-t holds"], s["runs"], s["normal holds"], s["runs"]])
