"""Changes between groups tested with the terrain as the unit, on the committed paper study."""

import itertools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from offroadbench.study.stats.clustered import wilcoxon_test
from offroadbench.study.stats.terrain import terrain_changes

RESULTS = Path(__file__).resolve().parents[2] / "experiments" / "results"


def trials_from_terrain_counts(terrains: pd.DataFrame) -> pd.DataFrame:
    """Trial rows with the per-terrain success counts of a report's terrains.csv (the order of
    successes within a terrain does not matter to any per-terrain statistic)."""
    rows = []
    for r in terrains.itertuples(index=False):
        for m in range(int(r.trials)):
            rows.append({"cell": r.cell, "terrain": r.terrain, "mission": m, "success": m < r.successes})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def paper():
    ter = pd.read_csv(RESULTS / "majhor2023" / "terrains.csv")
    labels = {c: f"D_high = {d}" for c, d in ter.groupby("cell")["D_high"].first().items()}
    return trials_from_terrain_counts(ter), ter, labels


def test_low_area_falls_on_every_terrain_and_the_test_says_so(paper):
    trials, ter, labels = paper
    tab = terrain_changes(trials, ter, labels, ["area_low_pct", "success_rate_pct"])
    low = tab[tab["quantity"] == "area_low_pct"]
    n = ter["terrain"].nunique()
    # issue 22: the low-roughness area falls on 20 of 20 terrains at both steps
    assert (low["down"] == n).all() and (low["terrains"] == n).all()
    assert np.allclose(low["p_wilcoxon"], 2 / 2**n) and np.allclose(low["p_sign_flip"], 2 / 2**n)
    assert (low["ci95_high"] < 0).all() and low["significant"].all()
    assert all(int(d.split(" of ")[0]) <= 2000 for d in low["bootstrap_distinct"])


def test_success_change_matches_a_direct_wilcoxon_and_holm_covers_the_table(paper):
    trials, ter, labels = paper
    tab = terrain_changes(trials, ter, labels, ["area_low_pct", "success_rate_pct"])
    cells = sorted(labels)
    rate = ter.set_index(["cell", "terrain"])["success_rate_pct"]
    for c0, c1 in itertools.pairwise(cells):
        d = (rate.loc[c1] - rate.loc[c0]).to_numpy()
        row = tab[(tab["quantity"] == "success_rate_pct") & (tab["from"] == labels[c0])].iloc[0]
        assert row["p_wilcoxon"] == pytest.approx(wilcoxon_test(d))
        assert row["mean_change"] == pytest.approx(d.mean())
        assert row["ci95_low"] <= d.mean() <= row["ci95_high"]
    ranks = tab["p_wilcoxon"].rank(method="first").astype(int)
    assert (tab["p_holm"] >= tab["p_wilcoxon"]).all()
    smallest = tab.loc[ranks == 1]
    assert float(smallest["p_holm"].iloc[0]) == pytest.approx(min(1.0, len(tab) * float(smallest["p_wilcoxon"].iloc[0])))


def test_unpaired_groups_use_independent_samples(paper):
    # the same numbers read as independent groups: the same change, but the terrain-to-terrain
    # spread is no longer cancelled, so the interval is wider and the p larger than paired
    trials, ter, labels = paper
    un = terrain_changes(trials, ter, labels, ["area_low_pct"], paired=False)
    pa = terrain_changes(trials, ter, labels, ["area_low_pct"], paired=True)
    assert un["p_sign_flip"].isna().all()
    assert np.allclose(un["mean_change"], pa["mean_change"])
    assert ((un["ci95_high"] - un["ci95_low"]) > (pa["ci95_high"] - pa["ci95_low"])).all()
    assert (un["p_wilcoxon"] > pa["p_wilcoxon"]).all()


def test_report_tests_each_change_at_the_terrain_level(tmp_path):
    from offroadbench.study import run_study, study_from_dict
    from offroadbench.study.report.markdown import build_report
    from offroadbench.study.spec.config import plan_cells

    def fake(prepared, settings):
        hm = prepared.hm
        for m in prepared.missions:
            (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
            z = hm.height_at(np.linspace(sx, gx, 41), np.linspace(sy, gy, 41))
            rough = float(np.abs(np.diff(z)).max())
            yield {"mission_index": m.index, "success": rough < 0.05, "failure_reason": "" if rough < 0.05 else "stuck",
                   "traversal_time_s": 3.0 + rough, "rms_vertical_accel_m_s2": rough, "rms_pitch_rate_deg_s": rough,
                   "rms_roll_rate_deg_s": 100 * rough, "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy}

    study = study_from_dict({
        "study": {"name": "t", "recipe": "paper-d2.45", "root_seed": 5, "terrains_per_cell": 4, "missions_per_terrain": 3},
        "grid": {"recipe.layers.base.D_high": [2.3, 2.6]},
        "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
        "roughness": {"border_m": 0.5}, "missions": {"length_m": 3.0, "border_m": 0.5},
        "reference": {"source": "test", "trials": [12, 12], "successes": [11, 5],
                      "median_change": {"rms_roll_rate_deg_s": [[1.0, 10.0]], "area_low_pct": [[-5.0, float("nan")]]}},
    })
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake)
    rep = build_report(tmp_path)
    assert "## Changes at the terrain level" in rep.markdown
    tab = rep.tables["terrain_changes.csv"]
    assert set(tab["quantity"]) >= {"success_rate_pct", "area_low_pct", "rms_roll_rate_deg_s"}
    assert (tab["terrains"] <= 4).all() and tab["p_holm"].notna().any()
    ref = rep.tables["reference_median_changes.csv"].set_index("quantity")
    col = "significant at the terrain level"
    assert col in ref and ref.loc["area_low_pct", "terrains"] == 4
    # 4 terrains cannot give p < 0.05 (the smallest exact two-sided p is 2 / 16): never "yes"
    assert (ref[col] != "yes").all()


def test_median_change_intervals_resample_terrains_in_both_groups():
    from offroadbench.study.stats.terrain import group_summary, median_change_intervals, median_changes

    rows = []
    for j in range(8):
        for m in range(4):
            rows.append({"cell": 0, "terrain": j, "mission": m, "success": m < 2, "failure_reason": "",
                         "rms_vertical_accel_m_s2": 1.0 + 0.1 * j, "traversal_time_s": 10.0})
            rows.append({"cell": 1, "terrain": j, "mission": m, "success": True, "failure_reason": "",
                         "rms_vertical_accel_m_s2": 1.5 + 0.1 * j, "traversal_time_s": 10.0})
    trials = pd.DataFrame(rows)
    terrains = pd.DataFrame([{"cell": c, "terrain": j, "area_low": 0.5, "area_semi": 0.3, "area_high": 0.2}
                             for c in (0, 1) for j in range(8)])
    labels = {0: "a", 1: "b"}
    changes = median_changes(group_summary(trials, terrains, labels), ["success_rate_pct", "rms_vertical_accel_m_s2"])
    out = median_change_intervals(trials, terrains, changes, labels, n_boot=300).set_index("quantity")
    # every terrain gains 50 points: no resample can give anything else
    assert out.loc["success_rate_pct", ["change", "ci95_low", "ci95_high"]].tolist() == [50.0, 50.0, 50.0]
    # the same terrains in both groups: every terrain's metric is 0.5 higher, so is every resample's median
    assert out.loc["rms_vertical_accel_m_s2", "ci95_low"] == pytest.approx(0.5)
    assert out.loc["rms_vertical_accel_m_s2", "ci95_high"] == pytest.approx(0.5)
