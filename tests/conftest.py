import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from offroadbench.heightmap import Heightmap


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def small_paper_recipe():
    """The D = 2.45 paper preset on a 161 x 161 grid (8 m at 5 cm): fast, same physics of roughness."""
    from offroadbench.terrain.recipe import apply_overrides, load_recipe

    return apply_overrides(load_recipe("paper-d2.45"), {"grid.rows": 161, "grid.cols": 161})


@pytest.fixture
def flat_map():
    return Heightmap.flat(21, 31, 0.1, z_m=1.5)


#: the maps and missions of the small test studies: 257^2 paper maps (12.8 m), 6 m missions 1 m from the edge
SMALL_MAPS_TOML = """
[recipe_overrides]
"grid.rows" = 257
"grid.cols" = 257

[roughness]
border_m = 1.0

[missions]
length_m = 6.0
border_m = 1.0
"""

#: A study small enough for executor and crash tests: two D values on 257^2 paper maps, 6 m missions.
TINY_STUDY_TOML = """
[study]
name = "{name}"
recipe = "paper-d2.45"
root_seed = {root_seed}
terrains_per_cell = {terrains}
missions_per_terrain = {missions}

[grid]
"recipe.layers.base.D_high" = [2.3, 2.6]
""" + SMALL_MAPS_TOML


@pytest.fixture(scope="session")
def write_tiny_study():
    """``write_tiny_study(directory, name=, root_seed=, terrains=, missions=)`` writes
    ``directory/study.toml`` (2 x terrains x missions trials) and returns its path."""

    def write(directory, *, name: str, root_seed: int, terrains: int, missions: int):
        path = directory / "study.toml"
        path.write_text(TINY_STUDY_TOML.format(name=name, root_seed=root_seed, terrains=terrains, missions=missions))
        return path

    return write


@pytest.fixture(scope="session")
def stored_trials():
    """``stored_trials(run_dir)``: rows in a run's store so far (0 before it exists), read-only."""
    import sqlite3

    def count(run_dir) -> int:
        db = run_dir / "study.sqlite"
        if not db.exists():
            return 0
        try:
            con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5)
            try:
                return con.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
            finally:
                con.close()
        except sqlite3.Error:  # tables not created yet
            return 0

    return count


@pytest.fixture(scope="session")
def example_plugin_site(tmp_path_factory) -> Path:
    """The example plug-in package (examples/offroadbench-example-planner): a copy built and installed
    with pip into a temporary target folder (not the source tree), once per session; the folder to
    put on PYTHONPATH. The tests only read it."""
    example = Path(__file__).resolve().parents[1] / "examples" / "offroadbench-example-planner"
    tmp = tmp_path_factory.mktemp("example-plugin")
    src, site = tmp / "src", tmp / "site"
    shutil.copytree(example, src)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target",
                    str(site), str(src)], check=True, capture_output=True)
    assert (site / "offroadbench_example_planner" / "__init__.py").is_file()
    return site
