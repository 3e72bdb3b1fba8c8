"""Rigid-wheel terramechanics on soft soil (Wong & Reece 1967; Ishigami et al. 2007): pure functions
and lookup tables, no physics engine.

The wheel (radius ``r``, width ``b``) sinks ``h`` into the soil; the contact spans the angles
``0 <= theta <= theta_1`` measured from the vertical below the axle, positive towards the direction
of travel, with the entry angle ``theta_1 = acos(1 - h / r)`` and the exit angle 0 (no rebound).

* **Normal stress** (Wong & Reece 1967, Eq. 1-2, with Bekker's pressure-sinkage law
  ``p = (k_c / b + k_phi) z^n``): in front of the maximum-stress angle ``theta_m``
  ``sigma(theta) = (k_c / b + k_phi) r^n (cos(theta) - cos(theta_1))^n``; behind it the same law at
  the equivalent front angle ``theta_1 - theta / theta_m (theta_1 - theta_m)``.
* **Maximum-stress angle** from the slip (Wong & Reece 1967): ``theta_m = (a_0 + a_1 |s|) theta_1``.
* **Slip-sinkage** (Ding et al. 2011, J. Terramechanics 48, the slip-dependent sinkage exponent
  ``N = n0 + n1 s``): the exponent of the normal stress is ``n(s) = n + n1 |s|``, so at the same
  load a slipping wheel sinks deeper (with ``z < 1 m``, a larger exponent means a softer soil) and
  a spinning wheel digs itself in. Wong & Reece's model alone barely changes the sinkage with slip
  (9.2 -> 10.0 mm from slip 0 to 0.9 for the Husky on lunar regolith in lunar gravity), against
  single-wheel tests where it grows severalfold (Ding et al. 2010: 3-7x at slip 0.6 with lugged
  wheels; Lyasko 2010 reviews the effect). ``n1`` is a soil parameter (``soils/*.toml``) that must
  cite its published value (``n1_source``: author, year, page or table); no shipped soil has one
  that we could read (Ding et al. fit ``n1`` to their own wheels on their own simulant), so every shipped soil has ``n1 = 0``, the model without
  slip-sinkage, and ``soil check`` shows the published band beside it where one exists
  (``soils/data/slip-sinkage-*.csv``). The moduli keep their values as ``n`` varies (as Ding et
  al. do), so their units follow ``n(s)``.
* **Shear stress** (Janosi & Hanamoto 1961): ``tau = (c + sigma tan(phi)) (1 - exp(-|j| / K))``, signed as
  ``j`` (the soil resists the displacement either way), with the
  shear displacement of a driven wheel (Wong & Reece 1967, Eq. 7)
  ``j(theta) = r [(theta_1 - theta) - (1 - s)(sin(theta_1) - sin(theta))]``, slip ``s = 1 - v / (r omega)``
  in [0, 1]; for a skidding wheel (``|v| > |r omega|``, ``s = r omega / v - 1`` in [-1, 0]) the same
  displacement measured over the distance travelled, ``j = r [(1 + s)(theta_1 - theta) - (sin(theta_1)
  - sin(theta))]`` (a locked wheel, ``s = -1``, drags the soil by ``r (sin(theta_1) - sin(theta))``).
  Both forms meet at ``s = 0``.
* **Resultants** per wheel (Ishigami et al. 2007, Eq. 5-7): normal load
  ``F_z = r b int (tau sin + sigma cos) dtheta``, drawbar pull ``F_x = r b int (tau cos - sigma sin)
  dtheta``, driving resistance torque ``T = r^2 b int tau dtheta``.
* **Lateral force** (Ishigami et al. 2007, Eq. 9-10, side-shear part): ``F_y = r b int tau_y dtheta``,
  ``tau_y = (c + sigma tan(phi)) (1 - exp(-j_y / K_y))``, ``j_y = r lambda (theta_1 - theta)`` with the
  lateral slip ratio ``lambda = |v_y| / max(|r omega|, |v|)`` (``(1 - s) tan(beta)`` of Ishigami for a
  driven wheel). Ishigami's second term, the bulldozing resistance of the soil pushed sideways by
  the wheel's side face, is left out: it needs the soil's density and a passive-earth-pressure
  model that no soil file here gives a source for; the lateral force is therefore a lower bound.

Tables. :func:`build_tables` evaluates these integrals once per (soil, wheel) on a grid of
penetration and slip (Gauss-Legendre quadrature on both sides of ``theta_m``), and the per-step code
(:class:`SoilTables` lookups, :mod:`offroadbench.sim.soil_contact`) interpolates them with plain
scalar Python arithmetic. The penetration ``delta`` indexing the tables is the soil's sinkage plus
the deflection of a series spring ``k_series`` (the tyre, capped for the stability of the explicit
60 Hz step): ``delta = h + F_z(h, s) / k_series``, solved for ``h`` when the tables are built, so a
very stiff soil (heavy clay: tens of micrometres under a small robot) stays stable.

Portability. The tables are computed bit for bit alike on every x86-64 CPU: numpy picks its
``sin``/``cos``/``exp``/``arccos``/``power`` loops by the CPU it runs on (AVX-512, AVX2 and SSE
loops round differently in the last bit) and ``leggauss`` takes its nodes from LAPACK, so the
elementary functions here go through Python's ``math`` (the C library, as every per-step number
does), the quadrature nodes come from a Newton iteration in plain floats (:func:`gauss_legendre`)
and the quadrature sums run node by node in a fixed order (:func:`_quadrature`). numpy's
elementwise ``+ - * /``, ``sqrt``, ``abs`` and comparisons are exactly rounded on every CPU and stay.

Validity. Bekker's moduli are fitted to plate tests at 1 g. Tests of wheels under reduced gravity
(parabolic flights; Kobayashi et al. 2010, Wong 2012) found that a wheel in lunar gravity sinks and
slips more than the same wheel loaded to the same weight in 1 g: the soil's own weight, which
confines it, is smaller too. Nothing here models that: the same (k_c, k_phi, n) are used at every
gravity, so results in reduced gravity are those of a light wheel on Earth soil, not a validated
prediction. Keep the gravity and the soil visible beside every result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from functools import lru_cache

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.sim.tyre_laws.soils import (DEFAULT_SOIL, SlipSinkageBand, SoilParams, list_soils, load_soil,
                                              published_slip_sinkage, soil_files)

__all__ = [
    "DEFAULT_SOIL",
    "SoilParams",
    "SlipSinkageBand",
    "SoilTables",
    "build_tables",
    "capacity_n",
    "entry_angle",
    "gauss_legendre",
    "lateral_force",
    "list_soils",
    "load_soil",
    "max_stress_angle",
    "normal_stress",
    "published_slip_sinkage",
    "shear_displacement",
    "soil_files",
    "static_sinkage",
    "wheel_forces",
]

#: deepest soil sinkage the tables cover, as a fraction of the wheel radius (theta_1 = 75.5 deg);
#: beyond it the normal force rises with the series spring alone
MAX_SINKAGE_FRACTION = 0.75
#: lateral slip ratio scale of the table's axis w = lambda / (lambda + LAMBDA_SCALE) in [0, 1]
LAMBDA_SCALE = 0.2


# ---------------------------------------------------------------------------- portable elementary functions
def _elementwise(fn, nargs: int):
    """``fn`` of Python's ``math`` applied element by element, returning float arrays (module docstring,
    "Portability": numpy's own transcendental loops depend on the CPU's SIMD level)."""
    ufunc = np.frompyfunc(fn, nargs, 1)

    def apply(*args):
        return np.asarray(ufunc(*(np.asarray(a, dtype=float) for a in args)), dtype=float)

    return apply


_sin = _elementwise(math.sin, 1)
_cos = _elementwise(math.cos, 1)
_exp = _elementwise(math.exp, 1)
_acos = _elementwise(math.acos, 1)
_pow = _elementwise(math.pow, 2)


@lru_cache(maxsize=8)
def gauss_legendre(order: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Gauss-Legendre nodes (ascending) and weights on [-1, 1] for ``order`` points, in plain floats.

    Newton's iteration on ``P_n`` from the three-term recurrence ``k P_k = (2k - 1) x P_{k-1} - (k - 1) P_{k-2}``
    started at Tricomi's estimate ``cos(pi (i - 1/4) / (n + 1/2))``, the weights ``2 / ((1 - x^2) P_n'(x)^2)``
    (Abramowitz & Stegun 1964, Eq. 25.4.29); the same bits on every CPU (module docstring).
    """
    nodes, weights = [], []
    for i in range(1, order + 1):
        x = math.cos(math.pi * (i - 0.25) / (order + 0.5))
        for _ in range(100):
            p0, p1 = 1.0, x
            for k in range(2, order + 1):
                p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
            dp = order * (x * p1 - p0) / (x * x - 1.0)
            step = p1 / dp
            x -= step
            if abs(step) <= 1e-16:
                break
        p0, p1 = 1.0, x
        for k in range(2, order + 1):
            p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
        dp = order * (x * p1 - p0) / (x * x - 1.0)
        nodes.append(x)
        weights.append(2.0 / ((1.0 - x * x) * dp * dp))
    return tuple(nodes[::-1]), tuple(weights[::-1])


def _quadrature(weights, values):
    """``sum_k weights[..., k] values[..., k]`` over the last axis, node by node in a fixed order."""
    weights, values = np.broadcast_arrays(weights, values)
    total = np.zeros(values.shape[:-1])
    for k in range(values.shape[-1]):
        total = total + weights[..., k] * values[..., k]
    return total


# ---------------------------------------------------------------------------- the model
def entry_angle(radius_m, sinkage_m):
    """theta_1 = acos(1 - h / r), rad (0 for h <= 0)."""
    return _acos(np.clip(1.0 - np.asarray(sinkage_m, dtype=float) / radius_m, -1.0, 1.0))


def max_stress_angle(soil: SoilParams, theta1, slip):
    """theta_m = (a0 + a1 |s|) theta_1, rad (Wong & Reece 1967)."""
    return (soil.a0 + soil.a1 * np.abs(slip)) * theta1


def normal_stress(soil: SoilParams, radius_m: float, width_m: float, theta, theta1, theta_m, slip=0.0):
    """sigma(theta), Pa (Wong & Reece 1967, Eq. 1-2) with the exponent ``n(s)`` of the slip ``s``
    (:meth:`SoilParams.exponent`); arrays broadcast, 0 outside [0, theta_1]."""
    theta = np.asarray(theta, dtype=float)
    front = theta >= theta_m
    with np.errstate(divide="ignore", invalid="ignore"):
        equiv = np.where(front, theta, theta1 - theta / np.where(theta_m > 0, theta_m, 1.0) * (theta1 - theta_m))
    base = np.clip(_cos(equiv) - _cos(theta1), 0.0, None)
    n = soil.exponent(slip)
    sigma = soil.modulus(width_m) * _pow(radius_m, n) * _pow(base, n)
    return np.where((theta >= 0) & (theta <= theta1), sigma, 0.0)


def shear_displacement(radius_m: float, theta, theta1, slip):
    """j(theta), m: driven (s >= 0, Wong & Reece 1967, Eq. 7) or skidding (s < 0) form (module docstring)."""
    slip = np.asarray(slip, dtype=float)
    d_angle = theta1 - np.asarray(theta, dtype=float)
    d_sin = _sin(theta1) - _sin(theta)
    driven = radius_m * (d_angle - (1.0 - slip) * d_sin)
    skid = radius_m * ((1.0 + slip) * d_angle - d_sin)
    return np.where(slip >= 0.0, driven, skid)


def _nodes(theta1, theta_m, order: int):
    """Gauss-Legendre nodes and weights on [0, theta_m] and [theta_m, theta_1] (the stress has a
    kink at theta_m): arrays of shape (..., 2 * order)."""
    x, w = (np.array(a) for a in gauss_legendre(order))
    theta1 = np.asarray(theta1, dtype=float)[..., None]
    theta_m = np.asarray(theta_m, dtype=float)[..., None]
    lo_half, hi_half = theta_m / 2.0, (theta1 - theta_m) / 2.0
    nodes = np.concatenate([lo_half * (x + 1.0), theta_m + hi_half * (x + 1.0)], axis=-1)
    weights = np.concatenate([lo_half * w, hi_half * w], axis=-1)
    return nodes, weights


def wheel_forces(soil: SoilParams, radius_m: float, width_m: float, sinkage_m, slip, order: int = 24):
    """(F_z, F_x, T): normal load N, drawbar pull N, resistance torque N m of a rigid wheel at
    sinkage ``h`` and slip ``s`` in [-1, 1] (Ishigami et al. 2007, Eq. 5-7); arrays broadcast."""
    h, s = np.broadcast_arrays(np.asarray(sinkage_m, dtype=float), np.asarray(slip, dtype=float))
    theta1 = entry_angle(radius_m, h)
    theta_m = max_stress_angle(soil, theta1, s)
    th, w = _nodes(theta1, theta_m, order)
    t1, tm, ss = theta1[..., None], theta_m[..., None], s[..., None]
    sigma = normal_stress(soil, radius_m, width_m, th, t1, tm, ss)
    j = shear_displacement(radius_m, th, t1, ss)
    tau = (soil.cohesion_pa + sigma * math.tan(math.radians(soil.friction_angle_deg))) * np.sign(j) * (
        1.0 - _exp(-np.abs(j) / soil.shear_modulus_m))
    rb = radius_m * width_m
    sin_th, cos_th = _sin(th), _cos(th)
    fz = rb * _quadrature(w, tau * sin_th + sigma * cos_th)
    fx = rb * _quadrature(w, tau * cos_th - sigma * sin_th)
    torque = radius_m * rb * _quadrature(w, tau)
    return fz, fx, torque


def lateral_force(soil: SoilParams, radius_m: float, width_m: float, sinkage_m, slip, lateral_slip,
                  order: int = 24):
    """Side-shear force magnitude, N (Ishigami et al. 2007, Eq. 9-10 without bulldozing): lateral
    slip ratio ``lambda`` >= 0 (``inf``: fully developed shear); arrays broadcast."""
    h, s, lam = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (sinkage_m, slip, lateral_slip)))
    theta1 = entry_angle(radius_m, h)
    theta_m = max_stress_angle(soil, theta1, s)
    th, w = _nodes(theta1, theta_m, order)
    sigma = normal_stress(soil, radius_m, width_m, th, theta1[..., None], theta_m[..., None], s[..., None])
    jy = radius_m * np.where(np.isinf(lam), 1.0, lam)[..., None] * (theta1[..., None] - th)
    develop = np.where(np.isinf(lam)[..., None], 1.0, 1.0 - _exp(-jy / soil.lateral_shear_modulus_m))
    tau_y = (soil.cohesion_pa + sigma * math.tan(math.radians(soil.friction_angle_deg))) * develop
    return radius_m * width_m * _quadrature(w, tau_y)


# ---------------------------------------------------------------------------- tables
@dataclass(frozen=True, eq=False)
class SoilTables:
    """Wheel forces on a (penetration, slip[, lateral slip]) grid, for scalar per-step lookups.

    Axes: penetration ``delta`` at ``delta_max (i / n_delta)^2`` (dense near touch-down, where the
    force changes fastest), slip ``s = -1 + 2 j / (n_slip - 1)``, lateral axis
    ``w = lambda / (lambda + LAMBDA_SCALE) = k / (n_lat - 1)``. Row-major flat Python lists of floats.
    """

    soil: SoilParams
    radius_m: float
    width_m: float
    k_series_n_m: float
    delta_max_m: float
    n_delta: int
    n_slip: int
    n_lat: int
    sinkage: list
    """Soil sinkage h(delta, s), m."""
    fz: list
    fx: list
    torque: list
    fy: list
    """Lateral force (delta, s, w), N."""

    def _cell(self, delta: float, slip: float) -> tuple[int, float, int, float]:
        u = math.sqrt(delta / self.delta_max_m) * self.n_delta if delta > 0.0 else 0.0
        i = int(u)
        if i >= self.n_delta:
            i, fi = self.n_delta - 1, 1.0
        else:
            fi = u - i
        v = (min(1.0, max(-1.0, slip)) + 1.0) * 0.5 * (self.n_slip - 1)
        j = int(v)
        if j >= self.n_slip - 1:
            j = self.n_slip - 2
        return i, fi, j, v - j

    def outside(self, delta_m: float) -> bool:
        """True where the penetration ``delta_m`` passes the table's top ``delta_max_m``: the soil has
        reached its sinkage cap (``MAX_SINKAGE_FRACTION`` of the radius) at some slip and what carries
        the wheel beyond it is the series spring alone, not the Wong-Reece model (the wheel bottoms out)."""
        return delta_m > self.delta_max_m

    def lookup(self, delta_m: float, slip: float) -> tuple[float, float, float, float]:
        """(sinkage m, F_z N, F_x N, T N m) at penetration ``delta_m`` >= 0 and slip in [-1, 1]
        (bilinear; past ``delta_max`` the normal force grows with the series spring alone)."""
        i, fi, j, fj = self._cell(delta_m, slip)
        ns = self.n_slip
        a, b = i * ns + j, (i + 1) * ns + j
        w00, w01, w10, w11 = (1.0 - fi) * (1.0 - fj), (1.0 - fi) * fj, fi * (1.0 - fj), fi * fj
        out = []
        for t in (self.sinkage, self.fz, self.fx, self.torque):
            out.append(t[a] * w00 + t[a + 1] * w01 + t[b] * w10 + t[b + 1] * w11)
        extra = delta_m - self.delta_max_m
        if extra > 0.0:
            out[1] = out[1] + self.k_series_n_m * extra
        return out[0], out[1], out[2], out[3]

    def lateral(self, delta_m: float, slip: float, lateral_slip: float) -> float:
        """Side-shear force magnitude, N, at penetration, slip and lateral slip ratio >= 0 (trilinear)."""
        i, fi, j, fj = self._cell(delta_m, slip)
        w = lateral_slip / (lateral_slip + LAMBDA_SCALE) * (self.n_lat - 1)
        k = int(w)
        if k >= self.n_lat - 1:
            k = self.n_lat - 2
        fk = w - k
        nl, ns = self.n_lat, self.n_slip
        total = 0.0
        for di, wi in ((0, 1.0 - fi), (1, fi)):
            for dj, wj in ((0, 1.0 - fj), (1, fj)):
                base = ((i + di) * ns + j + dj) * nl + k
                total = total + wi * wj * (self.fy[base] * (1.0 - fk) + self.fy[base + 1] * fk)
        return total


@lru_cache(maxsize=32)
def build_tables(soil: SoilParams, radius_m: float, width_m: float, k_series_n_m: float, *,
                 n_delta: int = 48, n_slip: int = 41, n_lat: int = 13, n_fine: int = 160) -> SoilTables:
    """Evaluate the wheel's forces on the table grid (see :class:`SoilTables`), once per process for
    each (soil, wheel, spring) (about 1.6 s; the tables are read-only).

    The soil's sinkage ``h`` at each penetration ``delta`` solves ``delta = h + F_z(h, s) / k_series``
    (interpolated on ``n_fine`` sinkages up to ``MAX_SINKAGE_FRACTION * r``).
    """
    check_range(None, "wheel radius_m", radius_m, lo=0, lo_open=True)
    check_range(None, "wheel width_m", width_m, lo=0, lo_open=True)
    check_range(None, "k_series_n_m", k_series_n_m, lo=0, lo_open=True)
    if soil.modulus(width_m) <= 0:
        raise InputError(f"soil {soil.name!r}: k_c / b + k_phi = {soil.modulus(width_m):g} <= 0 for a "
                         f"{width_m:g} m wide wheel")
    h_max = MAX_SINKAGE_FRACTION * radius_m
    u_fine = np.linspace(0.0, 1.0, n_fine)
    h_fine = h_max * (u_fine * u_fine)
    slips = np.linspace(-1.0, 1.0, n_slip)
    fz_f, _, _ = wheel_forces(soil, radius_m, width_m, h_fine[:, None], slips[None, :])
    fz_f = np.maximum(fz_f, 0.0)
    delta_f = np.maximum.accumulate(h_fine[:, None] + fz_f / k_series_n_m, axis=0)  # (fine, slip)
    delta_max = float(delta_f[-1].min())
    u_delta = np.arange(n_delta + 1) / n_delta
    deltas = delta_max * (u_delta * u_delta)
    sink = np.empty((n_delta + 1, n_slip))
    for j in range(n_slip):
        sink[:, j] = np.interp(deltas, delta_f[:, j], h_fine)
    fz, fx, torque = wheel_forces(soil, radius_m, width_m, sink, slips[None, :])
    w = np.linspace(0.0, 1.0, n_lat)
    with np.errstate(divide="ignore"):
        lam = np.where(w < 1.0, LAMBDA_SCALE * w / np.where(w < 1.0, 1.0 - w, 1.0), np.inf)
    fy = lateral_force(soil, radius_m, width_m, sink[:, :, None], slips[None, :, None], lam[None, None, :])

    def flat(a):
        return [float(x) for x in np.asarray(a, dtype=float).ravel()]

    return SoilTables(soil=soil, radius_m=float(radius_m), width_m=float(width_m), k_series_n_m=float(k_series_n_m),
                      delta_max_m=delta_max, n_delta=n_delta, n_slip=n_slip, n_lat=n_lat, sinkage=flat(sink),
                      fz=flat(np.maximum(fz, 0.0)), fx=flat(fx), torque=flat(torque), fy=flat(fy))


def capacity_n(soil: SoilParams, radius_m: float, width_m: float, slip: float = 0.0) -> float:
    """The largest normal load the model carries at slip ``s``: ``F_z`` at the table's sinkage cap
    ``MAX_SINKAGE_FRACTION * r``, N. A wheel loaded beyond it bottoms out (outside the model)."""
    return float(wheel_forces(soil, radius_m, width_m, MAX_SINKAGE_FRACTION * radius_m, slip)[0])


def static_sinkage(soil: SoilParams, radius_m: float, width_m: float, load_n: float, slip: float = 0.0) -> float:
    """Sinkage h at which the wheel carries ``load_n`` at slip ``s``, m (bisection on F_z(h, s)); the
    cap ``MAX_SINKAGE_FRACTION * r`` where the soil cannot carry the load (:func:`capacity_n`)."""
    lo, hi = 0.0, MAX_SINKAGE_FRACTION * radius_m
    if float(wheel_forces(soil, radius_m, width_m, hi, slip)[0]) < load_n:
        return hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if float(wheel_forces(soil, radius_m, width_m, mid, slip)[0]) < load_n:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)

