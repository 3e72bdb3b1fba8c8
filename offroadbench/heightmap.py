"""The one terrain type every part of offroadbench speaks.

Convention (shared/DESIGN.md): ``z`` is float64 metres of shape ``(rows, cols)`` and
``z[r, c]`` is the height at ``x = c * cell_size_m``, ``y = r * cell_size_m``. A PNG
pixel at (row r, col c) is ``z[r, c]``; no flips anywhere. Plots use ``origin="lower"``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError

__all__ = ["Heightmap"]

MIN_SIDE = 3


@dataclass(frozen=True, eq=False)
class Heightmap:
    """A regular-grid digital elevation map.

    Attributes:
        z: heights in metres, float64, shape ``(rows, cols)``, at least 3 x 3. The array is
            copied on construction and made read-only, so a Heightmap never changes.
        cell_size_m: grid spacing in metres (> 0), the same along x and y.
    """

    z: np.ndarray
    cell_size_m: float

    def __post_init__(self) -> None:
        z = np.array(self.z, dtype=np.float64, copy=True)
        if z.ndim != 2:
            raise InputError(f"heightmap z must be a 2-D array, got {z.ndim} dimension(s)")
        if z.shape[0] < MIN_SIDE or z.shape[1] < MIN_SIDE:
            raise InputError(f"heightmap must be at least {MIN_SIDE}x{MIN_SIDE} cells, got {z.shape[0]}x{z.shape[1]}")
        bad = ~np.isfinite(z)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            raise InputError(
                f"heightmap z has {int(bad.sum())} NaN/inf height(s), first at row {r}, col {c}; "
                "heights must be finite (fill gaps first)"
            )
        cell = float(self.cell_size_m)
        if not np.isfinite(cell) or cell <= 0:
            raise InputError(f"cell_size_m must be a finite number > 0, got {self.cell_size_m!r}")
        from offroadbench.bounds import check_bounds, check_heights

        check_bounds(self, "heightmap")  # a physical grid spacing (offroadbench.bounds.CELL_SIZE)
        z_range = (float(z.min()), float(z.max()))
        check_heights(*z_range)  # physical heights (offroadbench.bounds.HEIGHT_M)
        z.setflags(write=False)
        object.__setattr__(self, "_z_range", z_range)  # the read-only map's extremes, found once
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "cell_size_m", cell)

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the grid."""
        return self.z.shape  # type: ignore[return-value]

    @property
    def rows(self) -> int:
        return self.z.shape[0]

    @property
    def cols(self) -> int:
        return self.z.shape[1]

    @property
    def width_m(self) -> float:
        """Extent along x in metres, from the first to the last sample: ``(cols - 1) * cell``."""
        return (self.cols - 1) * self.cell_size_m

    @property
    def height_m(self) -> float:
        """Extent along y in metres, from the first to the last sample: ``(rows - 1) * cell``."""
        return (self.rows - 1) * self.cell_size_m

    @property
    def extent_m(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) in metres, sample centres; matplotlib's ``extent`` order."""
        return (0.0, self.width_m, 0.0, self.height_m)

    @property
    def z_min_m(self) -> float:
        """The lowest height, metres (found once: the map is read-only)."""
        return self._z_range[0]

    @property
    def z_max_m(self) -> float:
        """The highest height, metres (found once: the map is read-only)."""
        return self._z_range[1]

    @property
    def relief_m(self) -> float:
        """max(z) - min(z) in metres."""
        return self.z_max_m - self.z_min_m

    def x_coords_m(self) -> np.ndarray:
        """x of every column, metres."""
        return np.arange(self.cols) * self.cell_size_m

    def y_coords_m(self) -> np.ndarray:
        """y of every row, metres."""
        return np.arange(self.rows) * self.cell_size_m

    def contains(self, x_m, y_m, margin_m: float = 0.0):
        """True where (x, y) lies inside the map, at least ``margin_m`` from its edge."""
        x = np.asarray(x_m, dtype=float)
        y = np.asarray(y_m, dtype=float)
        return (x >= margin_m) & (x <= self.width_m - margin_m) & (y >= margin_m) & (y <= self.height_m - margin_m)

    # ------------------------------------------------------------------ lookup
    def height_at(self, x_m, y_m):
        """Bilinear height in metres at (x, y) metres; scalars or arrays of one shape.

        Points outside the map raise ``InputError``: a silent clamp would hide an off-map vehicle.
        """
        x = np.asarray(x_m, dtype=float)
        y = np.asarray(y_m, dtype=float)
        tol = 1e-9 * self.cell_size_m
        if np.any((x < -tol) | (x > self.width_m + tol) | (y < -tol) | (y > self.height_m + tol)):
            raise InputError(
                f"height_at: point(s) outside the map; x must be in [0, {self.width_m:g}] m and "
                f"y in [0, {self.height_m:g}] m"
            )
        fc = np.clip(x / self.cell_size_m, 0, self.cols - 1)
        fr = np.clip(y / self.cell_size_m, 0, self.rows - 1)
        c0 = np.minimum(np.floor(fc).astype(int), self.cols - 2)
        r0 = np.minimum(np.floor(fr).astype(int), self.rows - 2)
        tx = fc - c0
        ty = fr - r0
        z = self.z
        out = (
            z[r0, c0] * (1 - tx) * (1 - ty)
            + z[r0, c0 + 1] * tx * (1 - ty)
            + z[r0 + 1, c0] * (1 - tx) * ty
            + z[r0 + 1, c0 + 1] * tx * ty
        )
        return float(out) if out.ndim == 0 else out

    # ------------------------------------------------------------------ variants
    def with_z(self, z: np.ndarray) -> "Heightmap":
        """A new Heightmap with the same cell size and other heights."""
        return Heightmap(z=z, cell_size_m=self.cell_size_m)

    def rescaled(self, relief_m: float) -> "Heightmap":
        """Shift to min 0 and scale to the given relief (metres). A flat map stays flat at 0."""
        if not relief_m > 0:
            raise InputError(f"relief_m must be > 0, got {relief_m!r}")
        span = self.relief_m
        z = self.z - self.z_min_m
        if span > 0:
            z = z * (relief_m / span)
        return self.with_z(z)

    @classmethod
    def flat(cls, rows: int, cols: int, cell_size_m: float, z_m: float = 0.0) -> "Heightmap":
        """A flat map at height ``z_m``: handy for tests and as a crater base."""
        return cls(z=np.full((rows, cols), float(z_m)), cell_size_m=cell_size_m)

    def __repr__(self) -> str:
        return (
            f"Heightmap({self.rows}x{self.cols}, cell={self.cell_size_m:g} m, "
            f"z=[{self.z_min_m:.3f}, {self.z_max_m:.3f}] m)"
        )
