"""A tiny suite for the end-to-end tests: two categories on 161^2 maps, 4 m missions, a few trials."""

import tomllib

import pytest

TINY_SUITE = """
[suite]
name = "tiny-v1"
description = "two categories on 8 m maps"
vehicle = "husky"
sensor = "oracle"
nominal_speed_m_s = 1.0
time_clip_factors = [1.0, 3.0]
tasks_sha256 = "{sha}"

[tiers.quick]
description = "8 m maps, 4 m missions"

[[categories]]
name = "rough"
description = "paper terrain at two roughness levels"
[categories.study]
study = {{ recipe = "paper-d2.45", root_seed = 5 }}
grid = {{ "recipe.layers.base.D_high" = [2.3, 2.6] }}
recipe_overrides = {{ "grid.rows" = 161, "grid.cols" = 161, "layers.base.relief_m" = 1.5 }}
roughness = {{ border_m = 1.0 }}
missions = {{ length_m = 4.0, border_m = 1.0 }}
[categories.tiers.quick]
study = {{ terrains_per_cell = 2, missions_per_terrain = 1 }}

[[categories]]
name = "lunar"
description = "lunar mare in lunar gravity"
[categories.study]
study = {{ recipe = "lunar-mare", root_seed = 6 }}
recipe_overrides = {{ "grid.rows" = 161, "grid.cols" = 161, "layers.craters.population.d_max_m" = 2.0 }}
roughness = {{ border_m = 1.0 }}
missions = {{ length_m = 4.0, border_m = 1.0 }}
[categories.tiers.quick]
study = {{ terrains_per_cell = 2, missions_per_terrain = 1 }}
"""


def suite_text(template: str = TINY_SUITE) -> str:
    """The template with its tasks hash pinned (what a suite author does after editing tasks)."""
    from offroadbench.suite import tasks_sha256

    data = tomllib.loads(template.format(sha="x"))
    s = data["suite"]
    sha = tasks_sha256(data["categories"], s["vehicle"], s.get("sensor", ""), s["nominal_speed_m_s"], s["time_clip_factors"])
    return template.format(sha=sha)


@pytest.fixture
def tiny_suite(tmp_path):
    """The path of a tiny suite TOML with its hash pinned."""
    path = tmp_path / "tiny-v1.toml"
    path.write_text(suite_text())
    return path
