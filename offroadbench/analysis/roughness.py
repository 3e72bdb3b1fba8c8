"""Roughness classes from the Moore-neighbourhood gradient map, Majhor & Bos 2023, Sec. 2.3, Eq. (3)-(4).

Eq. (4): ``Q_grad = (Z_P - Z_Qi) / dist(P, Qi)`` for the 8 Moore neighbours Qi of pixel P, with
dist = cell (edge neighbours) or cell * sqrt(2) (corner neighbours); Eq. (3): the gradient map
is ``P_grad = max |Q_grad|``. Pixels are then ``low`` (P_grad <= t_low), ``semi``
(t_low < P_grad <= t_high) or ``high`` (P_grad > t_high).

Units. The paper's thresholds 50 and 140 are in 16-bit DEM units per centimetre, as its
5 / 7.07 cm distances say. Its Unreal import used Z scale 0.75 %: at Z scale 100 a 16-bit map
spans 512 m (128 DEM units per cm of height at scale 1; :func:`offroadbench.levels16.ue_z_range_m`),
so one DEM unit is 0.75/128 cm and the
thresholds in rise/run are 50 * 0.75/128 = 0.293 and 140 * 0.75/128 = 0.820. The one function
that converts is :func:`paper_gradient_to_slope`; here everything is metres and rise/run.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError

from offroadbench.config import check_range
from offroadbench.heightmap import Heightmap
from offroadbench.levels16 import LEVELS, ue_z_range_m

__all__ = [
    "LOW",
    "SEMI",
    "HIGH",
    "CLASS_NAMES",
    "paper_gradient_to_slope",
    "RoughnessConfig",
    "gradient_map",
    "classify",
    "close_rough",
    "class_fractions",
    "border_mask",
    "disk",
    "ClassMaps",
    "classify_terrain",
]

LOW, SEMI, HIGH = 0, 1, 2
CLASS_NAMES = ("low", "semi", "high")

#: The paper's Unreal Z scale, percent (Sec. 2.2).
PAPER_UE_Z_SCALE = 0.75


def paper_gradient_to_slope(grad_units_per_cm: float, ue_z_scale: float = PAPER_UE_Z_SCALE) -> float:
    """Convert a Majhor & Bos gradient threshold (16-bit DEM units per cm) to rise/run.

    One 16-bit unit is ``ue_z_range_m(ue_z_scale) / 65535`` of height = ``ue_z_scale / 128`` cm,
    so a gradient g units/cm is ``g * ue_z_scale / 128`` cm/cm. 50 -> 0.293, 140 -> 0.820.
    """
    cm_per_unit = ue_z_range_m(ue_z_scale) * 100.0 / LEVELS
    return grad_units_per_cm * cm_per_unit


@dataclass(frozen=True, kw_only=True)
class RoughnessConfig:
    """Thresholds and filters of the roughness classification (paper Sec. 2.3-2.4)."""

    low_max_slope: float = paper_gradient_to_slope(50.0)
    """Largest Moore gradient (rise/run) of a low-roughness pixel; paper 50 units/cm = 0.293."""
    semi_max_slope: float = paper_gradient_to_slope(140.0)
    """Largest Moore gradient (rise/run) of a semi-rough pixel; paper 140 units/cm = 0.820."""
    border_m: float = 5.0
    """Width of the map edge excluded from area fractions and mission ends, metres (paper: 5 m)."""
    closing_radius_m: float = 0.25
    """Radius of the disk used to morphologically close the rough areas, metres.

    The paper does not give it. 0.25 m (5 px at 5 cm) is about half the Husky's track and a
    wheel-and-a-half of radius: gaps between rough patches narrower than ~0.5 m are closed,
    because a 0.57 m-wide vehicle cannot start or stop inside them without touching both.
    """

    def __post_init__(self) -> None:
        check_range(self, "low_max_slope", self.low_max_slope, lo=0, lo_open=True)
        check_range(self, "semi_max_slope", self.semi_max_slope, lo=self.low_max_slope)
        check_range(self, "border_m", self.border_m, lo=0)
        check_range(self, "closing_radius_m", self.closing_radius_m, lo=0)


def gradient_map(hm: Heightmap) -> np.ndarray:
    """Eq. (3)-(4): max |Moore gradient| per pixel, rise/run (dimensionless).

    Edge pixels use only the neighbours that exist. Vectorised: 8 shifted differences.
    """
    z = hm.z
    h = hm.cell_size_m
    d = h * np.sqrt(2.0)
    g = np.zeros_like(z)
    # each neighbour pair is visited once and its |difference| applied to both pixels
    pairs = (
        ((slice(None), slice(1, None)), (slice(None), slice(None, -1)), h),  # left/right
        ((slice(1, None), slice(None)), (slice(None, -1), slice(None)), h),  # up/down
        ((slice(1, None), slice(1, None)), (slice(None, -1), slice(None, -1)), d),  # diagonal
        ((slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None)), d),  # anti-diagonal
    )
    for a, b, dist in pairs:
        diff = np.abs(z[a] - z[b]) / dist
        np.maximum(g[a], diff, out=g[a])
        np.maximum(g[b], diff, out=g[b])
    return g


def classify(hm: Heightmap, cfg: RoughnessConfig = RoughnessConfig()) -> np.ndarray:
    """Class map (uint8: LOW=0, SEMI=1, HIGH=2) from the gradient map and the thresholds."""
    g = gradient_map(hm)
    classes = np.full(g.shape, LOW, dtype=np.uint8)
    classes[g > cfg.low_max_slope] = SEMI
    classes[g > cfg.semi_max_slope] = HIGH
    return classes


def disk(radius_px: float) -> np.ndarray:
    """Boolean disk structuring element of the given radius in pixels (at least 1 pixel)."""
    r = int(np.floor(radius_px))
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    return (xx * xx + yy * yy) <= radius_px * radius_px + 1e-9


def close_rough(classes: np.ndarray, radius_m: float, cell_size_m: float) -> np.ndarray:
    """Morphological closing of the rough areas with a disk (paper Fig. 4b).

    Applied per level: the semi-or-high set and the high set are each closed, so rough areas
    grow into the thin low gaps between them and the class order is kept. Returns a new map.
    """
    radius_px = radius_m / cell_size_m
    if radius_px < 1:
        return classes.copy()
    if radius_px > max(classes.shape):  # e.g. a cell size in the wrong unit: a disk of 3.6 TiB
        raise InputError(f"closing_radius_m = {radius_m:g} m is {radius_px:.3g} cells at cell_size_m = {cell_size_m:g} m, "
                         f"more than the {classes.shape[0]}x{classes.shape[1]} map; check the cell size and its unit")
    se = disk(radius_px)
    pad = int(np.ceil(radius_px))
    out = np.full(classes.shape, LOW, dtype=np.uint8)
    for level in (SEMI, HIGH):
        # pad with 'not rough' so closing does not invent rough pixels at the map edge
        mask = np.pad(classes >= level, pad, mode="constant", constant_values=False)
        closed = _disk_close(mask, se)[pad:-pad, pad:-pad]
        out[closed] = level
    return out


def _row_runs(se: np.ndarray) -> list[tuple[int, int]] | None:
    """(row offset, half-width) of each row of the odd, centred structuring element ``se`` whose true
    pixels form one run centred on the middle column (a disk's rows do); None if a row does not."""
    r, c = se.shape[0] // 2, se.shape[1] // 2
    runs = []
    for k, row in enumerate(se):
        idx = np.flatnonzero(row)
        if idx.size == 0:
            continue
        w = c - int(idx[0])
        if int(idx[-1]) != c + w or idx.size != 2 * w + 1:
            return None
        runs.append((k - r, w))
    return runs


def _disk_close(mask: np.ndarray, se: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.binary_closing(mask, structure=se)`` (dilation, then erosion, the border
    ``False`` for both), the same pixels, computed row by row: a dilation (erosion) by a symmetric
    element whose rows are centred runs is the OR (AND) over its rows of whether any (every) pixel
    of the run's width along the row is set, shifted by the row's offset (van Herk 1992's
    decomposition into 1-D lines; the runs counted by running sums). About 4x faster than scipy's
    general binary erosion for the 11x11 disk of the paper maps (tests/analysis/test_roughness.py
    compares the two)."""
    from scipy.ndimage import binary_closing

    runs = _row_runs(se)
    if runs is None or se.shape[0] % 2 == 0 or se.shape[1] % 2 == 0 or se.shape[0] > mask.shape[0]:
        return binary_closing(mask, structure=se)
    return _by_rows(_by_rows(mask, runs, erode=False), runs, erode=True)


def _by_rows(mask: np.ndarray, runs, *, erode: bool) -> np.ndarray:
    """One dilation (``erode`` False) or erosion of ``mask`` by the element of ``runs``
    (:func:`_row_runs`), pixels outside the map ``False``."""
    rows, cols = mask.shape
    wmax = max(w for _, w in runs)
    # csum[:, j + wmax + 1] = set pixels of the row up to column j (zeros past either end)
    csum = np.zeros((rows, cols + 2 * wmax + 1), np.int32)
    np.cumsum(mask, axis=1, out=csum[:, wmax + 1:cols + wmax + 1])
    csum[:, cols + wmax + 1:] = csum[:, cols + wmax:cols + wmax + 1]
    lines: dict[int, np.ndarray] = {}
    combine = np.logical_and if erode else np.logical_or
    out = np.full(mask.shape, erode)
    for dy, w in runs:
        if w not in lines:  # set pixels in columns j - w .. j + w of each row
            count = csum[:, wmax + w + 1:wmax + w + 1 + cols] - csum[:, wmax - w:wmax - w + cols]
            lines[w] = count == 2 * w + 1 if erode else count > 0
        line = lines[w]
        if dy >= 0:  # out[i] takes line[i + dy]; rows past the edge: False
            combine(out[:rows - dy], line[dy:], out=out[:rows - dy])
            if erode and dy:
                out[rows - dy:] = False
        else:
            combine(out[-dy:], line[:rows + dy], out=out[-dy:])
            if erode:
                out[:-dy] = False
    return out


def border_mask(shape: tuple[int, int], border_m: float, cell_size_m: float) -> np.ndarray:
    """True for pixels at least ``border_m`` from every map edge (x, y measured from sample 0)."""
    rows, cols = shape
    y = np.arange(rows) * cell_size_m
    x = np.arange(cols) * cell_size_m
    ok_y = (y >= border_m - 1e-9) & (y <= y[-1] - border_m + 1e-9)
    ok_x = (x >= border_m - 1e-9) & (x <= x[-1] - border_m + 1e-9)
    return ok_y[:, None] & ok_x[None, :]


def class_fractions(classes: np.ndarray, cell_size_m: float, border_m: float = 5.0) -> dict[str, float]:
    """Area fraction (0..1) of each class inside the border, before any closing (paper Sec. 2.4)."""
    inside = border_mask(classes.shape, border_m, cell_size_m)
    total = int(inside.sum())
    if total == 0:
        from offroadbench.errors import InputError

        raise InputError(
            f"border_m = {border_m} m leaves no area on a {classes.shape[0]}x{classes.shape[1]} map "
            f"at {cell_size_m} m per cell"
        )
    vals = classes[inside]
    return {name: float(np.count_nonzero(vals == k)) / total for k, name in enumerate(CLASS_NAMES)}


@dataclass(frozen=True)
class ClassMaps:
    """The roughness classes of one terrain (Majhor & Bos 2023, Eq. 3-4 and Fig. 4a-b).

    ``classes`` and ``closed`` are read-only uint8 maps (0 low, 1 semi, 2 high) of the terrain's
    shape. ``fractions`` is the area fraction of each class inside the border, before closing
    (what the paper reports); ``closed_fractions`` the same after the closing. Both are computed
    on first use (a map smaller than twice its border has none: InputError).
    """

    classes: np.ndarray
    closed: np.ndarray
    cell_size_m: float
    border_m: float

    @functools.cached_property
    def fractions(self) -> dict[str, float]:
        return class_fractions(self.classes, self.cell_size_m, self.border_m)

    @functools.cached_property
    def closed_fractions(self) -> dict[str, float]:
        return class_fractions(self.closed, self.cell_size_m, self.border_m)


def classify_terrain(hm: Heightmap, cfg: RoughnessConfig = RoughnessConfig()) -> ClassMaps:
    """Classify ``hm`` and close the rough areas: the one pipeline every caller uses.

    Missions are drawn on ``closed``; the paper's area statistics come from ``classes``.
    """
    classes = classify(hm, cfg)
    closed = close_rough(classes, cfg.closing_radius_m, hm.cell_size_m)
    classes.setflags(write=False)
    closed.setflags(write=False)
    return ClassMaps(classes=classes, closed=closed, cell_size_m=hm.cell_size_m, border_m=cfg.border_m)
