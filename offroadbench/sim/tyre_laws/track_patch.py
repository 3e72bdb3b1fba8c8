"""The track patch: a tracked vehicle's belt on soft soil under the Bekker / Wong track relations,
pure functions and a lookup table, no physics engine (issue 47).

A track of contact length ``L`` and width ``b`` carrying a normal load ``W`` on a soil of Bekker
parameters ``(k_c, k_phi, n)``, Mohr-Coulomb ``(c, phi)`` and shear modulus ``K`` (Wong, *Theory of
Ground Vehicles*, 4th ed. 2008, ch. 2; Bekker 1956), with a uniform ground pressure:

* **Pressure and sinkage** (Bekker's pressure-sinkage law for a plate of width ``b``):
  ``p = W / (b L)``, ``z0 = (p / (k_c / b + k_phi))^(1 / n)``.
* **Motion resistance** (compaction; Bekker): the work of pressing a belt of width ``b`` to ``z0``
  per unit distance, ``R_c = b (k_c / b + k_phi) z0^(n + 1) / (n + 1)``.
* **Thrust with slip** (Janosi & Hanamoto 1961; Wong 2008, ch. 2): the shear displacement under the
  belt grows from its front, ``j(x) = i x`` at slip ``i``, so ``tau(x) = (c + p tan(phi)) (1 - exp(-i x / K))``
  and ``F = b int_0^L tau dx = (A c + W tan(phi)) [1 - K / (i L) (1 - exp(-i L / K))]`` with ``A = b L``.
* **Drawbar pull**: ``F - R_c``.

In the simulation the belt of a side is its road wheels' segments (``N`` wheels a side, each a
segment of length ``L / N``; offroadbench.sim.tyre_laws.soil_wheels applies them): each segment
takes its normal force from its own sinkage ``h`` under its road wheel, ``F_n = b (L / N) (k_c / b +
k_phi) h^n``; its thrust is its share of the whole belt's, ``b (L / N) (c + p tan(phi)) g(i L / K)``
with the belt's mean shear development ``g(u) = 1 - (1 - exp(-u)) / u``; its compaction resistance
is ``R_c / N`` at its own sinkage; its side force has the same form with the lateral slip and K_y.
Where the belt's pressure is uniform (flat ground) the segments sum to the closed forms above
exactly; where it is not, each segment answers to its own pressure. The shear's distribution along
the belt (less at the front, more at the rear) is averaged over the belt, so the belt exerts no pitch
moment from it. As for the wheel, the penetration ``delta`` of a segment is its sinkage plus a series
spring (the tyre / belt compliance, capped for the explicit step's stability):
``delta = h + F_n(h) / k_series``, tabulated once (:class:`SegmentTable`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from offroadbench.config import check_range
from offroadbench.sim.tyre_laws.soils import SoilParams

__all__ = ["SegmentTable", "TrackPatch", "compaction_resistance_n", "drawbar_pull_n", "segment_table",
           "shear_development", "track_sinkage_m", "track_thrust_n"]


@dataclass(frozen=True, kw_only=True)
class TrackPatch:
    """A track's belt as its road wheels' segments: contact length, width and segments a side."""

    contact_length_m: float
    """The belt's ground contact length L, m."""
    width_m: float
    """The belt's width b, m."""
    segments: int
    """Road wheels (segments) a side, N."""

    def __post_init__(self) -> None:
        check_range(self, "contact_length_m", self.contact_length_m, lo=0, lo_open=True)
        check_range(self, "width_m", self.width_m, lo=0, lo_open=True)
        check_range(self, "segments", self.segments, lo=1)

    @property
    def segment_length_m(self) -> float:
        """L / N, m."""
        return self.contact_length_m / self.segments


def _modulus(soil: SoilParams, width_m: float) -> float:
    return soil.k_c / width_m + soil.k_phi


def track_sinkage_m(soil: SoilParams, width_m: float, length_m: float, load_n: float) -> float:
    """Static sinkage of a belt b x L carrying ``load_n`` at uniform pressure, m (Bekker):
    ``z0 = (W / (b L) / (k_c / b + k_phi))^(1 / n)``."""
    return math.pow(load_n / (width_m * length_m) / _modulus(soil, width_m), 1.0 / soil.n)


def compaction_resistance_n(soil: SoilParams, width_m: float, sinkage_m: float) -> float:
    """Motion resistance of a belt of width ``b`` sunk ``z``, N: ``b (k_c / b + k_phi) z^(n+1) / (n+1)`` (Bekker)."""
    z = max(0.0, sinkage_m)
    return width_m * _modulus(soil, width_m) * math.pow(z, soil.n + 1.0) / (soil.n + 1.0)


def shear_development(u: float) -> float:
    """The belt's mean shear development ``g(u) = 1 - (1 - exp(-u)) / u`` for ``u = i L / K`` >= 0
    (0 at no slip, towards 1 as the slip grows); dimensionless."""
    u = abs(u)
    if u == 0.0:
        return 0.0
    return 1.0 + math.expm1(-u) / u  # expm1: no cancellation at small u


def track_thrust_n(soil: SoilParams, width_m: float, length_m: float, load_n: float, slip: float,
                   shear_modulus_m: float | None = None) -> float:
    """Thrust of a belt at slip ``i`` (Janosi & Hanamoto 1961; Wong 2008, ch. 2), N:
    ``(A c + W tan(phi)) [1 - K / (i L) (1 - exp(-i L / K))]``, signed as the slip."""
    k = soil.shear_modulus_m if shear_modulus_m is None else shear_modulus_m
    limit = width_m * length_m * soil.cohesion_pa + load_n * math.tan(math.radians(soil.friction_angle_deg))
    return math.copysign(limit * shear_development(slip * length_m / k), slip)


def drawbar_pull_n(soil: SoilParams, width_m: float, length_m: float, load_n: float, slip: float) -> float:
    """Thrust less compaction resistance of one belt carrying ``load_n`` at slip ``i`` >= 0, N."""
    z0 = track_sinkage_m(soil, width_m, length_m, load_n)
    return track_thrust_n(soil, width_m, length_m, load_n, slip) - compaction_resistance_n(soil, width_m, z0)


@dataclass(frozen=True, eq=False)
class SegmentTable:
    """A belt segment's sinkage against its penetration (series spring included), for per-step lookups."""

    soil: SoilParams
    patch: TrackPatch
    radius_m: float
    """The road wheel's radius, m (the belt runs under it)."""
    k_series_n_m: float
    delta_max_m: float
    """The table's top; past it the soil's sinkage cap (``h_max``) is reached (outside the model)."""
    h_max_m: float
    sinkage: list
    """Sinkage at ``delta_max (k / n)^2``, k = 0..n, m."""

    def normal_n(self, sinkage_m: float) -> float:
        """The segment's normal force at sinkage ``h``, N: ``b (L / N) (k_c / b + k_phi) h^n``."""
        p = self.patch
        return p.width_m * p.segment_length_m * _modulus(self.soil, p.width_m) * math.pow(max(0.0, sinkage_m),
                                                                                            self.soil.n)

    def outside(self, delta_m: float) -> bool:
        """True past the table's top (the belt bottomed out at the sinkage cap)."""
        return delta_m > self.delta_max_m

    def lookup(self, delta_m: float) -> tuple[float, float]:
        """(sinkage m, normal force N) at penetration ``delta_m`` >= 0 (past the top: the cap's sinkage,
        the force growing with the series spring alone)."""
        n = len(self.sinkage) - 1
        u = math.sqrt(delta_m / self.delta_max_m) * n if delta_m > 0.0 else 0.0
        i = int(u)
        if i >= n:
            h = self.sinkage[n]
            return h, self.normal_n(h) + self.k_series_n_m * (delta_m - self.delta_max_m)
        f = u - i
        h = self.sinkage[i] * (1.0 - f) + self.sinkage[i + 1] * f
        return h, self.normal_n(h)


@lru_cache(maxsize=32)
def segment_table(soil: SoilParams, patch: TrackPatch, radius_m: float, k_series_n_m: float, h_max_m: float,
                  n_points: int = 256) -> SegmentTable:
    """The segment's sinkage table: ``delta(h) = h + F_n(h) / k_series`` inverted on ``n_points``
    penetrations up to ``delta(h_max)`` (bisection per point, plain floats)."""
    check_range(None, "k_series_n_m", k_series_n_m, lo=0, lo_open=True)
    check_range(None, "h_max_m", h_max_m, lo=0, lo_open=True)
    probe = SegmentTable(soil, patch, radius_m, k_series_n_m, 0.0, h_max_m, [])

    def delta_of(h: float) -> float:
        return h + probe.normal_n(h) / k_series_n_m

    top = delta_of(h_max_m)
    sink = []
    for k in range(n_points + 1):
        target = top * (k / n_points) ** 2
        lo, hi = 0.0, h_max_m
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if delta_of(mid) < target else (lo, mid)
        sink.append(0.5 * (lo + hi))
    return SegmentTable(soil, patch, radius_m, k_series_n_m, top, h_max_m, sink)
