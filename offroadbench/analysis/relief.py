"""Where a map's relief lives: extreme tails ("spires") and percentile clipping.

The paper's multifractal recipe (Majhor & Bos 2023, Sec. 2.1) rescales the product of three W-M
surfaces to a 3.84 m relief. With the coordinate convention used here the product has one coherent
extreme at the map corner, so on the paper presets about 3 m of the 3.84 m relief sit in the top
0.1 % of samples (a spire a few cells wide) while 99.8 % of the heights lie within 0.4 m of each
other. Every exported 16-bit heightmap inherits that: most of its 65536 levels are spent on the
spire. :func:`tail_report` measures it; :func:`clip_percentile` is the opt-in remedy (a departure
from the paper, which neither mentions nor clips it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = ["TAIL_FRACTION", "TailReport", "tail_report", "check_clip_percentile", "clip_percentile"]

#: the fraction of samples in each tail that :func:`tail_report` examines (0.1 %)
TAIL_FRACTION = 0.001


@dataclass(frozen=True)
class TailReport:
    """How much of the relief the extreme ``fraction`` of samples at each end spans (metres)."""

    relief_m: float
    top_span_m: float
    """z_max minus the (1 - fraction) quantile: the height range of the highest samples."""
    bottom_span_m: float
    """The fraction quantile minus z_min: the height range of the lowest samples."""
    fraction: float

    @property
    def dominated(self) -> bool:
        """True when either tail spans more than half the relief (a spire or a pit)."""
        return max(self.top_span_m, self.bottom_span_m) > 0.5 * self.relief_m

    def message(self, remedy: str | None = None) -> str:
        """The warning; ``remedy`` replaces the default advice (the ``--clip-percentile P`` option)."""
        pct = 100 * self.fraction
        which = "top" if self.top_span_m >= self.bottom_span_m else "bottom"
        span = max(self.top_span_m, self.bottom_span_m)
        return (
            f"the {which} {pct:g} % of samples span {span:.3g} m of the {self.relief_m:.3g} m relief "
            f"({100 * span / self.relief_m:.0f} %): a narrow spike sets the height range (and the 16-bit step of "
            "exports); " + (remedy or "--clip-percentile P clips heights to the P..100-P percentiles (not in the paper)")
        )


def tail_report(hm: Heightmap, fraction: float = TAIL_FRACTION) -> TailReport:
    """Spans of the top and bottom ``fraction`` of samples (quantiles by linear interpolation)."""
    lo, hi = np.quantile(hm.z, [fraction, 1.0 - fraction])
    return TailReport(
        relief_m=hm.relief_m, top_span_m=float(hm.z_max_m - hi), bottom_span_m=float(lo - hm.z_min_m), fraction=fraction
    )


def check_clip_percentile(percentile: float) -> float:
    """``percentile`` as a float if 0 <= P < 50, else an InputError naming the allowed range."""
    p = float(percentile)
    if not 0 <= p < 50:
        raise InputError(f"--clip-percentile {percentile!r} is out of range; allowed: 0 <= P < 50")
    return p


def clip_percentile(hm: Heightmap, percentile: float) -> Heightmap:
    """Heights clipped to the ``percentile`` .. ``100 - percentile`` percentiles (0 <= P < 50).

    A departure from the paper (which keeps every height): it flattens the top of a spire and the
    floor of a pit to the percentile heights and leaves every other sample unchanged. The relief
    shrinks to the percentile range; nothing is rescaled.
    """
    p = check_clip_percentile(percentile)
    if p == 0:
        return hm
    lo, hi = np.percentile(hm.z, [p, 100 - p])
    return hm.with_z(np.clip(hm.z, lo, hi))
