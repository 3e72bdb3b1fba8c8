"""Height colour maps use percentile limits, so a corner spire does not flatten the colours."""

import numpy as np

from offroadbench import Heightmap
from offroadbench.plots.style import height_limits
from offroadbench.plots.terrain import plot_terrain_classes


def _spire_map():
    y, x = np.mgrid[0:60, 0:60] * 0.05
    z = 0.6 + 0.2 * np.sin(x) * np.cos(y)  # the bulk: 0.4 .. 0.8 m
    z[0:2, 0:2] = 3.84  # four corner cells: most of the relief
    return Heightmap(z, 0.05)


def test_limits_are_the_percentiles_and_extend_marks_the_clipped_ends():
    hm = _spire_map()
    lo, hi, extend = height_limits(hm.z)
    assert (lo, hi) == tuple(np.percentile(hm.z, [0.5, 99.5]))
    assert hi < 0.81 and extend == "both"
    assert height_limits(np.full((3, 3), 2.0)) == (1.5, 2.5, "neither")  # a flat map still gets a colour range


def test_terrain_figure_colours_span_the_bulk_not_the_spire():
    hm = _spire_map()
    fig = plot_terrain_classes(hm, np.zeros(hm.shape, dtype=int))
    height_images = [im for im in fig.axes[0].get_images() if im.get_cmap().name == "terrain"]
    assert len(height_images) == 1
    vmin, vmax = height_images[0].get_clim()
    assert vmax - vmin < 0.2 * hm.relief_m
