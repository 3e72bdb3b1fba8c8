"""What a closed-loop policy sees: the observation of ``offroadbench/Traverse-v0``, built in one place
for the Gymnasium env and for the trial runner (so a policy stress-tested by a study sees exactly
what it was trained on).

A Dict of

* ``state`` (float32, 10, see :data:`STATE_FIELDS`): the goal in the vehicle's heading frame (m;
  x forward, y left, horizontal), roll and pitch (rad, as in offroadbench.navigation.metrics), body
  roll, pitch and yaw rates (rad/s) and the base velocity in the body frame (forward, left, up; m/s);
* ``height_patch`` (float32, n x n): terrain heights relative to the base on a square grid centred
  on the vehicle and aligned with its heading (:func:`height_patch`).

Two forms of the same information. :func:`observation` gives the trial runner's, which every
policy of a study reads: under the ``mast`` sensor a sample the sensor has not measured is NaN
(offroadbench.navigation.sensor; never guessed flat). The Gymnasium env gives
:func:`finite_observation` of it, which stays inside its Box spaces (a learner's losses stay
finite): the unknown samples read :data:`UNKNOWN_FILL_M` and a third entry ``known`` (float32,
n x n) is 1.0 where the sample was measured and 0.0 where it is that fill, so a learner can tell the
two apart. :func:`nan_observation` turns the env's form back into the runner's, bit for bit.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.heightmap import Heightmap

__all__ = ["STATE_FIELDS", "UNKNOWN_FILL_M", "ObservationConfig", "height_patch", "observation", "finite_observation",
           "nan_observation"]

#: the entries of observation["state"], in order
STATE_FIELDS = (
    "goal_x_m", "goal_y_m", "roll_rad", "pitch_rad",
    "roll_rate_rad_s", "pitch_rate_rad_s", "yaw_rate_rad_s",
    "v_forward_m_s", "v_left_m_s", "v_up_m_s",
)

#: the Gymnasium env's ``height_patch`` where the sensor has no measurement (its ``known`` is 0), m
#: relative to the base: the base's own height, the value a policy's features give an unknown cell
#: (offroadbench.navigation.policies.ppo.features)
UNKNOWN_FILL_M = 0.0


@dataclass(frozen=True, kw_only=True)
class ObservationConfig:
    """The height patch of the observation."""

    patch_cells: int = 16
    """Side of the square height patch, samples."""
    patch_spacing_m: float = 0.1
    """Distance between height-patch samples, m (16 x 0.1 m: a 1.5 m square around a 1 m vehicle)."""

    def __post_init__(self) -> None:
        check_int(self, "patch_cells", self.patch_cells, lo=1, hi=512)
        check_range(self, "patch_spacing_m", self.patch_spacing_m, lo=0, lo_open=True)


def height_patch(hm: Heightmap, x_m: float, y_m: float, yaw_rad: float, cells: int, spacing_m: float,
                 fill_m: float, z_m: np.ndarray | None = None) -> np.ndarray:
    """Terrain heights (bilinear) on a ``cells x cells`` grid centred on (x, y), turned by ``yaw_rad``.

    ``patch[i, j]`` is the height at body-frame offset ``(x_b, y_b) = ((j - c) s, (i - c) s)`` with
    ``c = (cells - 1) / 2`` and ``s = spacing_m``: columns run forward, rows to the left, as
    ``z[r, c]`` runs along x and y of the map. Samples outside the map read ``fill_m``. ``z_m``
    (the map's shape) replaces ``hm.z``: a sensor's map, whose unknown (NaN) cells make the samples
    next to them NaN.
    """
    from scipy.ndimage import map_coordinates

    yb, xb, reach = _body_grid(cells, spacing_m)
    cos, sin = math.cos(yaw_rad), math.sin(yaw_rad)
    xw = x_m + cos * xb - sin * yb
    yw = y_m + sin * xb + cos * yb
    cell = hm.cell_size_m
    col = xw / cell
    row = yw / cell
    z = map_coordinates(hm.z if z_m is None else z_m, [row, col], order=1, mode="nearest")
    # a patch a cell or more inside the map on every side has no sample outside it (the samples lie
    # within ``reach`` of the centre): the mask is then all false and is skipped
    margin = reach + cell
    if not (margin <= x_m <= (hm.cols - 1) * cell - margin and margin <= y_m <= (hm.rows - 1) * cell - margin):
        outside = (col < 0) | (col > hm.cols - 1) | (row < 0) | (row > hm.rows - 1)
        z[outside] = fill_m
    return z


@functools.lru_cache(maxsize=8)
def _body_grid(cells: int, spacing_m: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The height patch's body-frame offsets (y_b, x_b: cells x cells, m; read-only) and the largest
    distance of a sample from the centre, m (over-estimated by 1 %), computed once per size."""
    offs = (np.arange(cells) - (cells - 1) / 2.0) * spacing_m
    yb, xb = np.meshgrid(offs, offs, indexing="ij")
    yb.flags.writeable = xb.flags.writeable = False
    return yb, xb, 1.01 * math.sqrt(2.0) * abs(float(offs[0]))


def observation(hm: Heightmap, cfg: ObservationConfig, goal_xy, pos, roll: float, pitch: float, yaw: float,
                rates, v_body, fill_m: float, z_m: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The observation of the vehicle at ``pos`` (x, y, z) with the given attitude, body rates and
    body velocity, heading for ``goal_xy`` (see the module docstring). Under a sensor, ``pos`` and
    ``yaw`` are the believed pose (with the true height) and ``z_m`` the sensor's map."""
    x, y, z = pos
    dx, dy = goal_xy[0] - x, goal_xy[1] - y
    cos, sin = math.cos(yaw), math.sin(yaw)
    state = np.array([cos * dx + sin * dy, -sin * dx + cos * dy, roll, pitch, *rates, *v_body], dtype=np.float32)
    patch = height_patch(hm, x, y, yaw, cfg.patch_cells, cfg.patch_spacing_m, fill_m, z_m)
    return {"state": state, "height_patch": (patch - z).astype(np.float32)}


def finite_observation(obs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The Gymnasium env's form of an :func:`observation` (module docstring): ``height_patch`` with its
    unknown (NaN) samples set to :data:`UNKNOWN_FILL_M`, and ``known`` (float32, the patch's shape),
    1.0 where the sample is a measurement (everywhere under the oracle; also off the map, whose
    samples read the fall-depth fill of :func:`height_patch`) and 0.0 where it is the fill."""
    patch = np.asarray(obs["height_patch"], dtype=np.float32)
    known = np.isfinite(patch)
    return {"state": obs["state"], "height_patch": np.where(known, patch, np.float32(UNKNOWN_FILL_M)),
            "known": known.astype(np.float32)}


def nan_observation(obs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The trial runner's form of an env observation: ``state`` and ``height_patch``, NaN where
    ``known`` is 0, which is what the built-in policies read
    (e.g. ``offroadbench.navigation.policies.ppo.features(nan_observation(obs))``). An observation
    without ``known`` (already the runner's form) is returned as its ``state`` and ``height_patch``."""
    patch = np.asarray(obs["height_patch"], dtype=np.float32)
    if "known" in obs:
        patch = np.where(np.asarray(obs["known"]) > 0, patch, np.float32(np.nan))
    return {"state": obs["state"], "height_patch": patch}
