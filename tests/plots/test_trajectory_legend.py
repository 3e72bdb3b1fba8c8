"""The trajectories figure's legend lists the outcomes that happened, not every possible one."""

from types import SimpleNamespace

import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.plots.traversal import plot_trajectories


def test_the_legend_lists_only_outcomes_that_happened():
    hm = Heightmap.flat(41, 41, 0.1, z_m=0.0)
    classes = np.zeros(hm.shape, dtype=int)
    missions = [SimpleNamespace(index=i, start_xy_m=(0.5, 0.5 + i), goal_xy_m=(3.5, 0.5 + i)) for i in range(3)]
    results = [SimpleNamespace(failure_reason=r) for r in ("", "stuck", "")]
    tel = {i: {"x_m": np.array([0.5, 2.0]), "y_m": np.array([0.5 + i, 0.5 + i])} for i in range(3)}
    fig = plot_trajectories(hm, classes, missions, tel, results)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["success", "stuck", "planned", "driven"]
    fig = plot_trajectories(hm, classes, missions[:1], {0: tel[0]}, results[:1])
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["success", "planned", "driven"]
