"""Registry of radial crater profiles ``h(r; diameter, degradation)``.

Every profile works in SI units (metres) for any crater size, from rover-scale craters of a
few decimetres to lander-scale craters of kilometres. Profiles take the normalised radius
``rho = r / (D/2)`` (0 at the centre, 1 at the rim) and return heights in metres.

Two stamping modes (see :mod:`offroadbench.terrain.craters.stamp`):

* ``replace`` (Martin et al. 2014, Yoshikawa & Nishiguchi): inside the rim (rho <= 1) the
  height is measured from a local plane fitted to the old terrain, which it replaces (the
  obliterated interior, Martin et al. 2014, Sec. III.A, Fig. 1); outside the rim the height is added to the
  existing terrain (the ejecta blanket, Martin et al. 2014, Fig. 2). The profile also receives ``delta_m``, the
  terrain height at the rim minus the plane height at the rim along the pixel's direction
  (``T_r - P_r`` of Martin et al. 2014, Eq. 5-10), so the rim joins the surroundings without a step.
* ``add`` (Li et al. 2022 kernels): the kernel is summed onto the terrain, as in their locally
  controlled spot noise (Li et al. 2022, Eq. 2); ``delta_m`` is ignored.

``degradation`` is 0 for a fresh crater and 1 for a fully degraded one (a shallow depression
with no rim, Martin et al. 2014, Sec. I.C). How it maps to each profile's parameters is documented per profile.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from offroadbench.registry import Registry

__all__ = [
    "CraterProfile",
    "PROFILES",
    "MODES",
    "register_profile",
    "get_profile",
    "profile_height",
    "melosh_depth_m",
    "melosh_rim_height_m",
    "martin_degradation_factors",
    "martin2014_height",
    "yoshikawa_height",
    "li_gaussian_height",
    "li_flat_floor_height",
    "li_fresh_height",
    "li_complex_height",
]

MODES = ("replace", "add")

HeightFn = Callable[[np.ndarray, float, float, np.ndarray | float], np.ndarray]


@dataclass(frozen=True)
class CraterProfile:
    """One registered profile.

    ``height(rho, diameter_m, degradation, delta_m)`` returns heights in metres; ``extent`` is
    the radius of the region it changes, in crater radii (rho units); ``mode`` is one of MODES.
    """

    name: str
    mode: str
    extent: float
    height: HeightFn
    summary: str


def _from_entry_point(name: str, obj: object) -> CraterProfile:
    """An installed package's entry point names a :class:`CraterProfile`."""
    if not isinstance(obj, CraterProfile):
        raise TypeError(f"entry point {name!r} must name a CraterProfile, got {type(obj).__name__}")
    if obj.mode not in MODES:
        raise ValueError(f"profile {name!r}: mode must be one of {MODES}, got {obj.mode!r}")
    return obj if obj.name == name else dataclasses.replace(obj, name=name)


#: every crater profile by name; installed packages add CraterProfile objects through the
#: entry-point group ``offroadbench.profiles``
PROFILES: Registry[CraterProfile] = Registry("crater profile", entry_point_group="offroadbench.profiles",
                                             adapt=_from_entry_point)


def register_profile(name: str, *, mode: str, extent: float, summary: str):
    """Decorator adding a profile function to :data:`PROFILES`."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")

    def deco(fn: HeightFn) -> HeightFn:
        PROFILES.add(name, CraterProfile(name=name, mode=mode, extent=extent, height=fn, summary=summary))
        return fn

    return deco


def get_profile(name: str) -> CraterProfile:
    """The registered profile ``name``; an unknown name suggests the closest known ones."""
    return PROFILES.get(name)


def profile_height(name: str, r_m, diameter_m: float, degradation: float = 0.0) -> np.ndarray:
    """Height (m) of profile ``name`` at radial distance ``r_m`` on flat ground (delta = 0)."""
    prof = get_profile(name)
    rho = np.asarray(r_m, dtype=float) / (0.5 * diameter_m)
    return prof.height(rho, float(diameter_m), float(degradation), 0.0)


# --------------------------------------------------------------------------- martin2014
def melosh_depth_m(diameter_m):
    """Martin et al. 2014, Eq. (1): fresh crater depth, rim crest to floor, H0 = 0.196 D^1.01 (metres)."""
    return 0.196 * np.power(diameter_m, 1.01)


def melosh_rim_height_m(diameter_m):
    """Martin et al. 2014, Eq. (2): fresh rim height above the surroundings, Hr0 = 0.036 D^1.01 (metres)."""
    return 0.036 * np.power(diameter_m, 1.01)


#: Depth kept by a fully degraded crater, as a fraction of H0. Martin et al. take the depth and
#: rim erosion factors from the outline figures of Ross's model, which they do not reproduce;
#: we use linear factors: rim Hr = (1 - s) Hr0 (no rim when fully degraded) and depth
#: H = (1 - 0.8 s) H0, so a fully degraded crater is a rimless depression 0.2 H0 deep.
FULLY_DEGRADED_DEPTH_FRACTION = 0.2


def martin_degradation_factors(degradation: float) -> tuple[float, float]:
    """(depth factor H/H0, rim factor Hr/Hr0) for degradation s in [0, 1] (see above)."""
    s = min(max(float(degradation), 0.0), 1.0)
    return 1.0 - (1.0 - FULLY_DEGRADED_DEPTH_FRACTION) * s, 1.0 - s


#: The Eq. (8) joining point beta is kept below this, so the ejecta keeps some width.
_BETA_MAX = 0.9


def _mcgetchin_m(x: np.ndarray, radius_m: float) -> np.ndarray:
    """McGetchin ejecta thickness 0.14 R^0.74 (r/R)^-3 with r/R = x + 1 (Martin et al. 2014, Eq. 9)."""
    return 0.14 * radius_m**0.74 * np.power(x + 1.0, -3.0)


def _mcgetchin_scale(radius_m: float, rim_m: float) -> float:
    """Factor lambda on McGetchin's thickness that keeps the blanket falling monotonically.

    With F_c joining h4(0) = Hr and h4(1) = 0, the blanket rises near its edge unless
    lambda M0 <= Hr / (11/16), M0 = 0.14 R^0.74 (see :func:`_martin_ejecta`).
    """
    m0 = 0.14 * radius_m**0.74
    if m0 <= 0.0 or rim_m <= 0.0:
        return 0.0
    return min(1.0, rim_m / (11.0 / 16.0 * m0))


def _martin_ejecta(x: np.ndarray, radius_m: float, rim_m: float) -> np.ndarray:
    """Martin et al. 2014, Eq. (9)-(10): h4 = McGetchin + F_c on 0 <= x <= 1, relative to the terrain.

    F_c is the linear corrective function that joins the blanket to the rim (h4(0) = Hr) and to
    the surroundings (h4(1) = 0), the two conditions Martin et al. 2014 states for it; the printed Eq. (10)
    coefficients do not meet both ends in a frame where the ejecta lies on the terrain, so we
    solve them. McGetchin's law (fitted for kilometre craters, R in metres) exceeds Melosh's
    rim height for craters below ~6 m; its amplitude is then scaled down just enough that the
    blanket still falls monotonically from the rim (no moat): :func:`_mcgetchin_scale`.
    A fully degraded crater (Hr = 0) has no blanket.
    """
    lam = _mcgetchin_scale(radius_m, rim_m)
    m0 = lam * 0.14 * radius_m**0.74
    mc = lam * _mcgetchin_m(x, radius_m)
    fc = (rim_m - m0) * (1.0 - x) - (m0 / 8.0) * x
    return mc + fc


def _martin_ejecta_slope(x: float, radius_m: float, rim_m: float) -> float:
    """d h4 / dx of :func:`_martin_ejecta`."""
    m0 = _mcgetchin_scale(radius_m, rim_m) * 0.14 * radius_m**0.74
    return -3.0 * m0 * (x + 1.0) ** -4 - (rim_m - m0) - m0 / 8.0


@register_profile(
    "martin2014",
    mode="replace",
    extent=2.0,
    summary="Martin et al. 2014: four joined polynomials with degradation, McGetchin ejecta (Martin et al. 2014, Eq. 1-10)",
)
def martin2014_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Martin, Parkes & Dunstan 2014 radial profile, Martin et al. 2014, Eq. (1)-(10).

    With x = 2r/D - 1 (Eq. 3), K = Hr0 - Hr + H and the rim level Tp = Hr + T_r - P_r:

    * bowl, Eq. (4): h1 = K x^2 + 2 K x + Hr0 on [-1, alpha] (the centre is at Hr - H);
    * interior rim, Eq. (5): h2 = K (alpha + 1) / alpha x^2 + Tp on [alpha, 0];
    * alpha, Eq. (6): (Tp - Hr0) / K. Fresh on flat ground alpha = 0 and the bowl meets the rim.
      If Tp > Hr0 (terrain at the rim above the plane) there is no rounding; the bowl parabola is
      then stretched to reach Tp at the rim. alpha is clipped to [-1, 0].
    * exterior rim cubic, Eq. (7), on [0, beta]: zero slope and height Hr at the rim, meeting
      the ejecta h4 at beta in value and slope (the conditions Martin et al. 2014 states; the printed cubic
      meets a mirrored bowl instead and would dig a moat outside degraded craters).
    * beta, Eq. (8): 3 (Hr0 - Hr) / (2 K) = -3/2 alpha on flat ground (the printed sign gives
      beta <= 0 for degraded craters, where Martin et al. 2014 says beta moves outwards), capped at 0.9.
    * ejecta, Eq. (9)-(10): see :func:`_martin_ejecta`.

    Heights for rho <= 1 are relative to the local plane (they include ``delta_m`` = T_r - P_r);
    for rho > 1 they are relative to the existing terrain. Zero beyond rho = 2 (x = 1).
    Degradation factors: :func:`martin_degradation_factors`.
    """
    rho = np.asarray(rho, dtype=float)
    d = float(diameter_m)
    h0, hr0 = float(melosh_depth_m(d)), float(melosh_rim_height_m(d))
    f_depth, f_rim = martin_degradation_factors(degradation)
    depth, rim = f_depth * h0, f_rim * hr0
    k = hr0 - rim + depth
    x = rho - 1.0
    delta = np.broadcast_to(np.asarray(delta_m, dtype=float), rho.shape)
    out = np.zeros_like(rho)

    inner = x <= 0.0
    if inner.any():
        xi = x[inner]
        top = rim + delta[inner]
        floor = rim - depth
        alpha = np.clip((top - hr0) / k, -1.0, 0.0)  # Eq. (6)
        # Eq. (4); when top > Hr0 the parabola through the floor is stretched to reach top
        k_bowl = np.where(top > hr0, top - floor, k)
        h1 = k_bowl * (xi + 1.0) ** 2 + floor
        safe_alpha = np.where(alpha < 0.0, alpha, -1.0)
        h2 = k * (alpha + 1.0) / safe_alpha * xi**2 + top  # Eq. (5)
        out[inner] = np.where((xi <= alpha) | (alpha >= 0.0), h1, h2)

    outer = (x > 0.0) & (x < 1.0)
    if outer.any():
        xo = x[outer]
        radius = 0.5 * d
        beta = min(max(1.5 * (hr0 - rim) / k, 0.0), _BETA_MAX)  # Eq. (8), sign-corrected
        h4 = _martin_ejecta(xo, radius, rim)
        if beta > 0.0:
            v = float(_martin_ejecta(np.array(beta), radius, rim)) - rim
            s = _martin_ejecta_slope(beta, radius, rim)
            c2 = (3.0 * v - s * beta) / beta**2
            c3 = (s * beta - 2.0 * v) / beta**3
            h3 = rim + c2 * xo**2 + c3 * xo**3  # Eq. (7)
            h4 = np.where(xo <= beta, h3, h4)
        out[outer] = h4
    return out


# --------------------------------------------------------------------------- yoshikawa
# Yoshikawa & Nishiguchi 2001, Eq. (10)-(11): the fitted profile of a ~1.7 km bowl crater, in units of the rim radius r1.
_Y_R0, _Y_H0, _Y_H1 = 0.844, 0.367, 0.038
_Y_ALPHA, _Y_A1, _Y_A2, _Y_A3, _Y_R2, _Y_BETA = 1.31, 3.13, -1.09, 2.55e-2, 1.054, 2.6


def _yoshikawa_raw(u: np.ndarray) -> np.ndarray:
    """Yoshikawa & Nishiguchi 2001, Eq. (11) in units of r1, u = r / r1: central, rim and outer parts."""
    central = _Y_H0 * np.power(np.clip(u, 0.0, None) / _Y_R0, _Y_ALPHA) - _Y_H0
    rim = _Y_A1 * (u - 1.0) ** 3 + _Y_A2 * (u - 1.0) ** 2 + _Y_H1
    outer = _Y_H1 * np.power(np.maximum(u - _Y_A3, 1e-9), -_Y_BETA)
    return np.where(u < _Y_R0, central, np.where(u < _Y_R2, rim, outer))


@register_profile(
    "yoshikawa",
    mode="replace",
    extent=2.0,
    summary="Yoshikawa & Nishiguchi: fitted central/rim/outer bowl profile (Yoshikawa & Nishiguchi 2001, Eq. 10-11)",
)
def yoshikawa_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Yoshikawa & Nishiguchi fitted bowl profile, Yoshikawa & Nishiguchi 2001, Eq. (10)-(11), with r1 = D/2.

    Depth h0 = 0.367 r1, rim height h1 = 0.038 r1 at r1, concave radius r0 = 0.844 r1.
    The outer part (r/r1 - a3)^-2.6 never reaches zero; the linear term
    ``- h(2 r1) (rho - 1)`` brings it to zero at rho = 2 (the window edge) and keeps h(r1) = h1.
    Inside the rim ``delta_m (r/r1)^2`` joins the plane-relative bowl to the terrain at the rim.
    Degradation (our choice, as for martin2014): heights below zero scale by the depth factor,
    above zero by the rim factor of :func:`martin_degradation_factors`.
    """
    rho = np.asarray(rho, dtype=float)
    r1 = 0.5 * float(diameter_m)
    f_depth, f_rim = martin_degradation_factors(degradation)
    h = _yoshikawa_raw(rho)
    edge = float(_yoshikawa_raw(np.array(2.0)))
    h = np.where(rho > 1.0, h - edge * (rho - 1.0), h)
    h = np.where(h < 0.0, f_depth * h, f_rim * h) * r1
    h = np.where(rho <= 1.0, h + np.asarray(delta_m, dtype=float) * np.minimum(rho, 1.0) ** 2, h)
    return np.where(rho < 2.0, h, 0.0)


# --------------------------------------------------------------------------- Li et al. 2022
#: Depth / diameter of a fresh simple crater (kernels 1-2): Li et al. cite h/D ~ 0.2 for the
#: freshest craters (Marchi et al. 2015, Eros).
LI_SIMPLE_DEPTH_RATIO = 0.2
#: Degradation vectors, relative change of each kernel parameter at degradation 1 (Li et al. 2022, Fig. 8):
#: simple craters lose depth 0.4 -> 0.1 (Delta a = -0.75); fresh craters (Delta kappa,
#: Delta gamma, Delta a) = (-0.3, -0.4, -0.25); complex craters (-0.05, -0.2, -0.1).
LI_DEGRADATION = {
    "li_gaussian": {"a": -0.75},
    "li_flat_floor": {"a": -0.75},
    "li_fresh": {"kappa": -0.3, "gamma": -0.4, "a": -0.25},
    "li_complex": {"kappa": -0.05, "gamma": -0.2, "a": -0.1},
}
#: Kernel 3 parameters scaled to the rim diameter D from Li et al. 2022, Table A.1 (fresh, 0 Gyr, rows for
#: D = 300 m, 1 km, 3 km): kappa ~ 0.05 D, a ~ 0.185 D, b ~ 8 / D^2, beta = 5, gamma = 4 / D^2.
LI_FRESH = {"kappa": 0.05, "a": 0.185, "b": 8.0, "beta": 5.0}
#: Kernel 4: Li et al. 2022 gives only Fig. 6's normalised shape (H_rim = 0.471, H_c = 0.2 at D_rim = 2);
#: we keep its ratio H_c / H_rim and choose H_rim = 0.03 D, a central uplift of e-folding
#: radius ~ D/6 (b = 40 / D^2) and beta = 5.
LI_COMPLEX = {"kappa": 0.03, "a": 0.03 * 0.2 / 0.471, "b": 40.0, "beta": 5.0}


def _scaled(name: str, param: str, value: float, degradation: float) -> float:
    """value * (1 + s * relative change) along the profile's degradation vector."""
    rel = LI_DEGRADATION[name].get(param, 0.0)
    return value * (1.0 + min(max(degradation, 0.0), 1.0) * rel)


def _li_simple(rho: np.ndarray, diameter_m: float, degradation: float, name: str, q: int, fwhm_factor: float):
    """Li et al. 2022, Eq. (3)-(5): -a exp(-(p.p / 2 sigma^2)^q), D_a = fwhm_factor * FWHM."""
    d = float(diameter_m)
    sigma = d / (fwhm_factor * 2.0 * math.sqrt(2.0 * math.log(2.0)))
    a = _scaled(name, "a", LI_SIMPLE_DEPTH_RATIO * d, degradation)
    r = rho * 0.5 * d
    return -a * np.exp(-((r**2 / (2.0 * sigma**2)) ** q))


@register_profile("li_gaussian", mode="add", extent=2.0, summary="Li et al. 2022 kernel 1: Gaussian bowl (Li et al. 2022, Eq. 3-5)")
def li_gaussian_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Kernel 1 (Li et al. 2022, Eq. 3, q1 = 1), apparent diameter D_a = 2.5 FWHM (Eq. 5) = D.

    Depth a = 0.2 D when fresh (Li et al. 2022, Sec. 3.3, h/D); degradation scales a along (Delta a = -0.75).
    """
    return _li_simple(np.asarray(rho, dtype=float), diameter_m, degradation, "li_gaussian", 1, 2.5)


@register_profile("li_flat_floor", mode="add", extent=2.0, summary="Li et al. 2022 kernel 2: flat-floored bowl (Li et al. 2022, Eq. 3-5)")
def li_flat_floor_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Kernel 2 (Li et al. 2022, Eq. 3, q2 = 2): flat floor, D_a = 2 FWHM (Eq. 5) = D.

    Eq. (3) writes exp(-b (p.p)^q) with b = 1/(2 sigma^2); for q = 2 we use the dimensionally
    consistent (p.p / (2 sigma^2))^q, equal to Eq. (3) for q = 1. Degradation as kernel 1.
    """
    return _li_simple(np.asarray(rho, dtype=float), diameter_m, degradation, "li_flat_floor", 2, 2.0)


def _li_ring(rho, diameter_m, degradation, name, params, sign):
    """kappa exp(-beta ln(gamma p.p)^2) + sign * a exp(-b p.p)   (Li et al. 2022, Eq. 6 / Eq. 12)."""
    d = float(diameter_m)
    kappa = _scaled(name, "kappa", params["kappa"] * d, degradation)
    a = _scaled(name, "a", params["a"] * d, degradation)
    gamma = _scaled(name, "gamma", 4.0 / d**2, degradation)  # Eq. (9)/(15): D_rim = 2 / sqrt(gamma)
    b, beta = params["b"] / d**2, params["beta"]
    r2 = (np.asarray(rho, dtype=float) * 0.5 * d) ** 2
    with np.errstate(divide="ignore"):
        ring = kappa * np.exp(-beta * np.log(gamma * r2) ** 2)
    ring = np.where(r2 > 0.0, ring, 0.0)
    return ring + sign * a * np.exp(-b * r2)


@register_profile("li_fresh", mode="add", extent=2.5, summary="Li et al. 2022 kernel 3: fresh crater with rim (Li et al. 2022, Eq. 6-11)")
def li_fresh_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Kernel 3 (Li et al. 2022, Eq. 6): kappa exp(-beta (ln(gamma p.p))^2) - a exp(-b p.p), D = D_rim.

    We read the bowl exponent as b p.p (not (p.p)^2): that is what makes Eq. (7)
    H_rim ~ kappa - a exp(-b/gamma) and the Table A.1 values (b ~ 8/D^2) consistent.
    Parameters: :data:`LI_FRESH`; degradation vector (Delta kappa, Delta gamma, Delta a) =
    (-0.3, -0.4, -0.25) at degradation 1 (Li et al. 2022, Sec. 3.3, Fig. 8).
    """
    return _li_ring(rho, diameter_m, degradation, "li_fresh", LI_FRESH, -1.0)


@register_profile("li_complex", mode="add", extent=2.5, summary="Li et al. 2022 kernel 4: complex crater, central uplift (Li et al. 2022, Eq. 12-16)")
def li_complex_height(rho, diameter_m: float, degradation: float, delta_m=0.0) -> np.ndarray:
    """Kernel 4 (Li et al. 2022, Eq. 12): kappa exp(-beta (ln(gamma p.p))^2) + a exp(-b p.p), D = D_rim.

    H_rim = kappa (Eq. 13), H_c = a (Eq. 14), D_rim = 2/sqrt(gamma) (Eq. 15). Parameters:
    :data:`LI_COMPLEX`; degradation vector (-0.05, -0.2, -0.1) (Li et al. 2022, Fig. 8).
    """
    return _li_ring(rho, diameter_m, degradation, "li_complex", LI_COMPLEX, 1.0)
