"""Tail report and percentile clipping (offroadbench.analysis.relief)."""

import numpy as np
import pytest

from offroadbench import Heightmap, InputError
from offroadbench.analysis.relief import clip_percentile, tail_report


def test_a_spire_is_reported_and_a_gaussian_field_is_not(rng):
    z = rng.normal(size=(100, 100)) * 0.1
    assert not tail_report(Heightmap(z, 0.1)).dominated
    z[0, 0] = 5.0  # one sample in 10 000: inside the top 0.1 %
    rep = tail_report(Heightmap(z, 0.1))
    assert rep.dominated and rep.top_span_m > 0.5 * rep.relief_m
    assert rep.top_span_m == pytest.approx(5.0 - np.quantile(z, 0.999))
    assert "top 0.1 % of samples span" in rep.message() and "--clip-percentile" in rep.message()
    z[0, 0], z[5, 5] = 0.0, -5.0  # a pit is the bottom tail
    rep = tail_report(Heightmap(z, 0.1))
    assert rep.dominated and rep.bottom_span_m > rep.top_span_m and "bottom" in rep.message()


def test_clip_percentile_flattens_only_the_tails(rng):
    z = rng.normal(size=(50, 40))
    hm = Heightmap(z, 0.2)
    out = clip_percentile(hm, 1.0)
    lo, hi = np.percentile(z, [1, 99])
    assert out.z_min_m == lo and out.z_max_m == hi
    inside = (z >= lo) & (z <= hi)
    assert np.array_equal(out.z[inside], z[inside])  # nothing else moves, nothing is rescaled
    assert np.count_nonzero(~inside) == pytest.approx(0.02 * z.size, abs=2)
    assert clip_percentile(hm, 0) is hm
    for bad in (-1, 50, 75):
        with pytest.raises(InputError, match="clip-percentile"):
            clip_percentile(hm, bad)
