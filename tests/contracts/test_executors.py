"""Contract over every registered executor: the same tiny study gives the same trial table
(and the same terrain table) as running it inline, whatever the executor and worker count."""

import pandas as pd
import pytest

from offroadbench.study import load, load_study, load_terrains, run_study
from offroadbench.study.execution.executors import EXECUTORS

@pytest.fixture(scope="module")
def reference(tmp_path_factory, write_tiny_study):
    d = tmp_path_factory.mktemp("executors")
    study, cells = load_study(write_tiny_study(d, name="contract", root_seed=5, terrains=1, missions=2))
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
    from offroadbench.study.execution.executors import get_executor

    with pytest.raises(InputError, match=r"unknown executor 'locl'; did you mean 'local'"):
        get_executor("locl")
