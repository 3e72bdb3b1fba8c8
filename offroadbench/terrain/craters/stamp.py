"""Stamping craters onto a terrain, one bounding window per crater.

For each crater (oldest first, so younger craters overprint older ones), on the pixels within
``extent`` crater radii of its centre only:

* ``replace`` profiles (martin2014, yoshikawa), Martin et al. 2014, Sec. III.A and Parkes & Martin 1999, Sec. 2.2: a plane is
  fitted (least squares) to the old terrain inside the rim: it stands for the average slope of the
  obliterated bowl region (Martin et al. 2014, Fig. 1). Inside the rim the new height is plane + profile; the
  profile receives ``T_r - P_r`` (terrain minus plane at the rim point in the pixel's direction)
  so the rim meets the surrounding terrain without a step. Outside the rim the ejecta profile is
  added to the existing terrain and falls to zero at the window edge (Martin et al. 2014, Fig. 2). An older
  crater's bowl under a new rim is therefore cut and re-formed, and its rim under a new
  blanket is buried but keeps its shape: overlapping craters blend.
* ``add`` profiles (Li kernels): the kernel is added to the terrain (Li et al. 2022, Eq. 2).

Optional realism (Martin et al. 2014, Sec. III.A):

* irregular rims: the rim radius along direction theta is ``R (1 + p(theta))``, p a periodic
  1-D fractal (fBm trace, matching start and end values) of standard deviation
  ``rim_irregularity`` (a fraction of the radius);
* fractal roughness by radial zone: an fBm overlay with its own fractal dimension inside the rim
  and on the ejecta, of rms ``roughness * H0`` (H0 = fresh Melosh depth), constant inside and
  fading linearly to zero from the rim to the edge of the ejecta.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.progress import ProgressFn, report
from offroadbench.terrain.craters.profiles import get_profile, melosh_depth_m
from offroadbench.terrain.craters.table import CraterTable
from offroadbench.terrain.fractal.fbm import fbm_surface, hurst_from_dimension

log = logging.getLogger(__name__)

__all__ = ["StampOptions", "rim_perturbations", "stamp_craters", "stamp_one"]

#: Samples of the periodic rim perturbation p(theta).
RIM_SAMPLES = 64
#: Rim perturbations are clipped to +-this fraction of the radius.
RIM_CLIP = 0.5
_PROGRESS_EVERY = 1000


@dataclass(frozen=True, kw_only=True)
class StampOptions:
    """How craters are stamped (realism options of Martin et al. 2014, Sec. III.A)."""

    rim_irregularity: float = 0.0
    """Std of the rim radius perturbation as a fraction of the radius; 0 = circular rims."""
    rim_fractal_dimension: float = 1.5
    """Fractal dimension of the 1-D rim perturbation, in (1, 2)."""
    roughness: float = 0.0
    """Rms of the fractal overlay as a fraction of the crater's fresh depth H0; 0 = none."""
    roughness_D_interior: float = 2.2
    """Fractal dimension of the overlay inside the rim (floor and wall)."""
    roughness_D_ejecta: float = 2.4
    """Fractal dimension of the overlay on the ejecta (rough near the rim, Martin et al. 2014, Sec. III.A)."""
    min_diameter_cells: float = 2.0
    """Craters smaller than this many cells are skipped (Martin et al. 2014, Sec. IV.A rejects sub-pixel craters)."""

    def __post_init__(self) -> None:
        check_range(self, "rim_irregularity", self.rim_irregularity, lo=0, hi=0.5)
        check_range(self, "rim_fractal_dimension", self.rim_fractal_dimension, lo=1, hi=2, lo_open=True, hi_open=True)
        check_range(self, "roughness", self.roughness, lo=0)
        check_range(self, "roughness_D_interior", self.roughness_D_interior, lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "roughness_D_ejecta", self.roughness_D_ejecta, lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "min_diameter_cells", self.min_diameter_cells, lo=0)


def rim_perturbations(count: int, irregularity: float, dimension: float, rng: np.random.Generator) -> np.ndarray:
    """(count, RIM_SAMPLES) periodic 1-D fBm traces p(theta) of std ``irregularity``.

    A 1-D fBm trace of dimension D has H = 2 - D and power ~ f^-(2H+1) (Yoshikawa & Nishiguchi 2001, Eq. 2 with E = 1).
    Harmonics start at 2 (harmonic 1 would only shift the crater). Periodic, so p(0) = p(2 pi).
    """
    if count == 0 or irregularity <= 0:
        return np.zeros((count, RIM_SAMPLES))
    hurst = 2.0 - dimension
    f = np.arange(RIM_SAMPLES // 2 + 1, dtype=float)
    amp = np.zeros_like(f)
    amp[2:] = f[2:] ** (-(2.0 * hurst + 1.0) / 2.0)
    coef = (rng.standard_normal((count, f.size)) + 1j * rng.standard_normal((count, f.size))) * amp
    p = np.fft.irfft(coef, n=RIM_SAMPLES, axis=1)
    p -= p.mean(axis=1, keepdims=True)
    std = p.std(axis=1, keepdims=True)
    p = p / np.where(std > 0, std, 1.0) * irregularity
    return np.clip(p, -RIM_CLIP, RIM_CLIP)


def _bilinear(a: np.ndarray, fr: np.ndarray, fc: np.ndarray) -> np.ndarray:
    """Bilinear sample of ``a`` at fractional (row, col), clamped to the array."""
    rows, cols = a.shape
    fr = np.clip(fr, 0.0, rows - 1.0)
    fc = np.clip(fc, 0.0, cols - 1.0)
    r0 = np.minimum(fr.astype(np.intp), max(rows - 2, 0))
    c0 = np.minimum(fc.astype(np.intp), max(cols - 2, 0))
    r1 = np.minimum(r0 + 1, rows - 1)
    c1 = np.minimum(c0 + 1, cols - 1)
    tr = fr - r0
    tc = fc - c0
    top = a[r0, c0] * (1 - tc) + a[r0, c1] * tc
    bot = a[r1, c0] * (1 - tc) + a[r1, c1] * tc
    return top * (1 - tr) + bot * tr


def _fit_plane(sub: np.ndarray, dx: np.ndarray, dy: np.ndarray, mask: np.ndarray) -> tuple[float, float, float]:
    """Least-squares plane z = p0 + a dx + b dy over the masked window pixels (Martin et al. 2014, Fig. 1)."""
    n = int(mask.sum())
    if n == 0:
        return float(sub.mean()), 0.0, 0.0
    zz = sub[mask]
    if n < 3:
        return float(zz.mean()), 0.0, 0.0
    xx = np.broadcast_to(dx[None, :], sub.shape)[mask]
    yy = np.broadcast_to(dy[:, None], sub.shape)[mask]
    sx, sy = xx.sum(), yy.sum()
    m = np.array(
        [[n, sx, sy], [sx, (xx * xx).sum(), (xx * yy).sum()], [sy, (xx * yy).sum(), (yy * yy).sum()]]
    )
    rhs = np.array([zz.sum(), (xx * zz).sum(), (yy * zz).sum()])
    try:
        p0, a, b = np.linalg.solve(m, rhs)
    except np.linalg.LinAlgError:
        return float(zz.mean()), 0.0, 0.0
    return float(p0), float(a), float(b)


def stamp_one(
    z: np.ndarray,
    cell_size_m: float,
    x_m: float,
    y_m: float,
    diameter_m: float,
    degradation: float,
    profile_name: str,
    rim: np.ndarray | None = None,
    noise: tuple[np.ndarray, np.ndarray] | None = None,
    roughness: float = 0.0,
) -> None:
    """Stamp one crater into the writable array ``z`` in place (see the module docstring).

    ``rim`` is the crater's rim perturbation p(theta) (RIM_SAMPLES values) or None for a
    circular rim; ``noise`` the (interior, ejecta) unit-std overlay fields of z's shape.
    """
    prof = get_profile(profile_name)
    radius = 0.5 * diameter_m
    grow = 1.0 + (float(rim.max()) if rim is not None else 0.0)
    reach = prof.extent * radius * grow
    rows, cols = z.shape
    c0 = max(0, int(np.ceil((x_m - reach) / cell_size_m)))
    c1 = min(cols, int(np.floor((x_m + reach) / cell_size_m)) + 1)
    r0 = max(0, int(np.ceil((y_m - reach) / cell_size_m)))
    r1 = min(rows, int(np.floor((y_m + reach) / cell_size_m)) + 1)
    if c0 >= c1 or r0 >= r1:
        return
    sub = z[r0:r1, c0:c1]
    dx = np.arange(c0, c1) * cell_size_m - x_m
    dy = np.arange(r0, r1) * cell_size_m - y_m
    r = np.sqrt(dy[:, None] ** 2 + dx[None, :] ** 2)
    if rim is not None:
        theta = np.arctan2(dy[:, None], dx[None, :])
        grid = np.linspace(-np.pi, np.pi, RIM_SAMPLES, endpoint=False)
        rad = radius * (1.0 + np.interp(theta, grid, rim, period=2 * np.pi))
    else:
        rad = radius
    rho = r / rad
    inside = rho < prof.extent
    if not inside.any():
        return

    if prof.mode == "replace":
        bowl = rho <= 1.0
        p0, a, b = _fit_plane(sub, dx, dy, bowl)
        plane = p0 + a * dx[None, :] + b * dy[:, None]
        # T_r - P_r only matters inside the rim: sample the rim point of each bowl pixel's direction
        delta = np.zeros_like(rho)
        rb = r[bowl]
        safe = np.where(rb > 0, rb, 1.0)
        ux = np.where(rb > 0, np.broadcast_to(dx[None, :], r.shape)[bowl] / safe, 1.0)
        uy = np.where(rb > 0, np.broadcast_to(dy[:, None], r.shape)[bowl] / safe, 0.0)
        rad_b = rad[bowl] if rim is not None else rad
        t_rim = _bilinear(sub, (y_m + rad_b * uy) / cell_size_m - r0, (x_m + rad_b * ux) / cell_size_m - c0)
        p_rim = p0 + rad_b * (a * ux + b * uy)
        delta[bowl] = t_rim - p_rim
        h = prof.height(rho, diameter_m, degradation, delta)
        new = np.where(bowl, plane + h, sub + h)
    else:
        new = sub + prof.height(rho, diameter_m, degradation, 0.0)

    if noise is not None and roughness > 0:
        amp = roughness * float(melosh_depth_m(diameter_m))
        fade = np.clip((prof.extent - rho) / (prof.extent - 1.0), 0.0, 1.0)
        w_in = np.clip((1.1 - rho) / 0.2, 0.0, 1.0)
        n_in = noise[0][r0:r1, c0:c1]
        n_out = noise[1][r0:r1, c0:c1]
        new = new + amp * fade * (w_in * n_in + (1.0 - w_in) * n_out)

    sub[inside] = new[inside]


def stamp_craters(
    hm: Heightmap,
    craters: CraterTable,
    rng: np.random.Generator,
    options: StampOptions = StampOptions(),
    progress: ProgressFn | None = None,
) -> Heightmap:
    """Stamp every crater of ``craters`` (in table order; use ``oldest_first()``) onto ``hm``.

    Degradation must be known for every crater (derive it from age first). ``rng`` drives the
    irregular rims and roughness overlays only.
    """
    if len(craters) and np.isnan(craters.degradation).any():
        i = int(np.flatnonzero(np.isnan(craters.degradation))[0])
        raise InputError(f"stamp_craters: crater {i} has no degradation; derive it from age first")
    z = np.array(hm.z, dtype=np.float64, copy=True)
    cell = hm.cell_size_m
    keep = craters.diameter_m >= options.min_diameter_cells * cell
    skipped = int((~keep).sum())
    if skipped:
        log.info("skipping %d crater(s) smaller than %g cells", skipped, options.min_diameter_cells)
    rims = rim_perturbations(len(craters), options.rim_irregularity, options.rim_fractal_dimension, rng)
    noise = None
    if options.roughness > 0:
        noise = (
            fbm_surface(hm.rows, hm.cols, hurst_from_dimension(options.roughness_D_interior), rng),
            fbm_surface(hm.rows, hm.cols, hurst_from_dimension(options.roughness_D_ejecta), rng),
        )
    use_rim = options.rim_irregularity > 0
    total = len(craters)
    xs, ys, ds, ss = craters.x_m, craters.y_m, craters.diameter_m, craters.degradation
    for i in range(total):
        if keep[i]:
            stamp_one(
                z, cell, float(xs[i]), float(ys[i]), float(ds[i]), float(ss[i]), craters.profile[i],
                rim=rims[i] if use_rim else None, noise=noise, roughness=options.roughness,
            )
        if (i + 1) % _PROGRESS_EVERY == 0 or i + 1 == total:
            report(progress, i + 1, total)
    return hm.with_z(z)
