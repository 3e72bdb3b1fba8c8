"""``[sim.mujoco_warp]``: plain settings, checked without Warp installed."""

from __future__ import annotations

import pytest

from offroadbench.config import from_dict
from offroadbench.errors import InputError
from offroadbench.sim.config import SimConfig


def test_cuda_graph_is_on_by_default_and_loads_from_a_study_table():
    assert SimConfig().mujoco_warp.cuda_graph is True
    sim = from_dict(SimConfig, {"engine": "mujoco_warp", "mujoco_warp": {"device": "cuda", "cuda_graph": False}})
    assert sim.mujoco_warp.cuda_graph is False and sim.mujoco_warp.device == "cuda"


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_a_cuda_graph_that_is_not_a_boolean_is_one_line_naming_it(value):
    with pytest.raises(InputError, match=r"cuda_graph = .*allowed true or false"):
        from_dict(SimConfig, {"mujoco_warp": {"cuda_graph": value}})
