"""Contract over every registered executor: the same tiny study gives the same trial table
(and the same terrain table) as running it inline, whatever the executor and worker count."""

import pandas as pd
import pytest

from offroadbench.study import load, load_study, load_terrains, run_study
from offroadbench.study.executors import EXECUTORS

TINY = """
[study]
name = "contract"
recipe = "paper-d2.45"
root_seed = 5
terrains_per_cell = 1
missions_per_terrain = 2

[grid]
"recipe.layers.base.D_high" = [2.3, 2.6]

[recipe_overrides]
"grid.rows" = 257
"grid.cols" = 257

[roughness]
border_m = 1.0

[missions]
length_m = 6.0
border_m = 1.0
"""


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("executors")
    (d / "study.toml").write_text(TINY)
    study, cells = load_study(d / "study.toml")
    run_study(study, cells, d / "reference", executor="inline")
    return study, cells, load(d / "reference"), load_terrains(d / "reference")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", EXECUTORS.names())
def test_executor_gives_the_inline_table(name, reference, tmp_path):
    if name == "dask":
        pytest.importorskip("distributed")
    study, cells, table, terrains = reference
    assert len(table) == 4
    run_study(study, cells, tmp_path / name, executor=name, workers=2)
    pd.testing.assert_frame_equal(load(tmp_path / name), table)
    pd.testing.assert_frame_equal(load_terrains(tmp_path / name), terrains)


def test_unknown_executor_suggests_the_closest():
    from offroadbench.errors import InputError
    from offroadbench.study.executors import get_executor

    with pytest.raises(InputError, match=r"unknown executor 'locl'; did you mean 'local'"):
        get_executor("locl")
