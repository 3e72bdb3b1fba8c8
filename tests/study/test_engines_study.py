"""experiments/engines.toml (issue 25): the sim-to-sim study, cut to a few trials on small maps,
drives identical terrains and missions on both physics engines."""

from __future__ import annotations

import importlib.util

import pytest

from offroadbench import resources
from offroadbench.config import load_toml
from offroadbench.study import load, run_study, study_from_dict
from offroadbench.study.spec.config import plan_cells

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")


def test_engines_study_cut_pairs_the_engines_on_identical_missions(tmp_path):
    data = load_toml(resources.study_files()["engines"])
    assert data["grid"]["sim.engine"] == ["pybullet", "mujoco"]
    data["study"].update(terrains_per_cell=1, missions_per_terrain=2)
    data["grid"]["recipe.layers.base.D_high"] = [2.3, 2.6]
    data["recipe_overrides"] = {"grid.rows": 161, "grid.cols": 161}
    data["roughness"]["border_m"] = 1.0
    data["missions"].update(length_m=4.0, border_m=1.0)
    study = study_from_dict(data)
    plans = plan_cells(study)
    summary = run_study(study, plans, tmp_path / "run", executor="inline")
    assert summary is not None
    df = load(tmp_path / "run")
    assert len(df) == 2 * 2 * 2
    engine_col = next(c for c in df.columns if c.endswith("engine"))
    assert set(df[engine_col]) == {"pybullet", "mujoco"}
    keys = ["start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]
    for _, group in df.groupby([c for c in df.columns if c.endswith("D_high")] + ["terrain", "mission"]):
        assert len(group) == 2
        assert (group[keys].iloc[0] == group[keys].iloc[1]).all()  # the same mission on both engines
        assert group["mission_seed"].nunique() == 1 and group["terrain_seed"].nunique() == 1
    assert df["failure_reason"].isin(["", "tipped", "stuck", "timeout", "off_map", "fell"]).all()
