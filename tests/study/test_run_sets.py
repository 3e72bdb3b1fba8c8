"""``study run --set KEY=VALUE``, the report's code provenance line, and the twin-variance statistic."""

import numpy as np
import pytest

from offroadbench.cli.study import apply_sets
from offroadbench.errors import InputError
from offroadbench.study.report.markdown import provenance_text
from offroadbench.study.spec.config import plan_cells, study_from_dict, study_id
from offroadbench.study.execution.tasks import unexplained_variance

BASE = {"study": {"name": "s", "recipe": "paper-d2.45", "root_seed": 1, "terrains_per_cell": 10},
        "grid": {"sim.engine": ["pybullet", "mujoco"]}, "recipe_overrides": {"grid.rows": 121, "grid.cols": 121}}


def test_study_sets_reach_study_settings_and_recipe_and_change_the_id():
    data = apply_sets(BASE, ["study.terrains_per_cell=2", "sim.physics_rate_hz=120", "layers.base.D_high=2.6"])
    assert data["study"]["terrains_per_cell"] == 2 and data["sim"]["physics_rate_hz"] == 120
    assert data["recipe_overrides"] == {"grid.rows": 121, "grid.cols": 121, "layers.base.D_high": 2.6}
    assert BASE["study"]["terrains_per_cell"] == 10  # the file's dict is left alone
    a, b = study_from_dict(BASE), study_from_dict(apply_sets(BASE, ["study.terrains_per_cell=2"]))
    assert study_id(a, plan_cells(a, check_sections=False)) != study_id(b, plan_cells(b, check_sections=False))
    with pytest.raises(InputError, match="grid axis"):
        apply_sets(BASE, ["sim.engine=mujoco"])
    with pytest.raises(InputError, match="study.FIELD"):
        apply_sets(BASE, ["study=3"])


def test_provenance_names_commit_and_dirty_tree():
    meta = {"version": "0.9+git.abc1234", "runs": [{"version": "0.9+git.abc1234"}, {"version": "0.9+git.def5678-dirty"}]}
    line = provenance_text(meta)
    assert "commit `abc1234`, clean tree" in line and "commit `def5678`, **dirty tree**" in line
    assert "not a git checkout" in provenance_text({"version": "0.9", "runs": []})


def test_unexplained_variance_of_a_surface_and_its_smooth_twin():
    rng = np.random.default_rng(0)
    smooth = np.outer(np.sin(np.linspace(0, 3, 50)), np.cos(np.linspace(0, 2, 50)))
    noise = rng.normal(size=smooth.shape)
    k = noise.var() / (smooth.var() + noise.var())
    # 1 - r^2 of (smooth + noise) against smooth: the noise's share of the variance
    assert unexplained_variance(smooth + noise, smooth) == pytest.approx(k, abs=0.02)
    assert unexplained_variance(smooth, 3 * smooth + 1) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("D", [2.45, 2.9, 2.99])
def test_twin_statistic_is_the_variance_share_of_the_terms_above_nyquist(D):
    """For one W-M surface (Eq. 1) the terms are plane waves of variance a_n^2 / 2 with a_n =
    gamma^((D-3) n), so the share of the variance above Nyquist is sum_{n > Nyquist} a_n^2 / sum_n a_n^2;
    1 - r^2 of the aliased surface against its band-limited twin (same phases) measures the same."""
    import dataclasses

    from offroadbench.terrain.fractal.wm import WMConfig, _powers, generate_wm, kept_harmonics
    from offroadbench.terrain.grid import GridConfig

    grid = GridConfig(rows=257, cols=257, cell_size_m=0.05, quantise="none")
    cfg = WMConfig(D=D, M=32, smoothing_sigma_px=0.0)
    band = dataclasses.replace(cfg, band_limited=True)
    aliased = generate_wm(cfg, grid, np.random.default_rng(1)).z
    limited = generate_wm(band, grid, np.random.default_rng(1)).z
    power = _powers(cfg.gamma, 2 * (cfg.D - 3) * kept_harmonics(cfg, grid)).sum()
    resolved = _powers(cfg.gamma, 2 * (cfg.D - 3) * kept_harmonics(band, grid)).sum()
    assert unexplained_variance(aliased, limited) == pytest.approx(1 - resolved / power, abs=0.01, rel=0.03)
