"""The sampling grid every terrain generator fills: one config, passed to each generator.

A recipe's ``[grid]`` table is a :class:`GridConfig`; every generator is called as
``fn(cfg, grid, rng) -> Heightmap`` and returns a ``grid.rows x grid.cols`` Heightmap at
``grid.cell_size_m`` (``z[r, c]`` at ``x = c * cell_size_m``, ``y = r * cell_size_m``).
"""

from __future__ import annotations

from dataclasses import dataclass

from offroadbench.bounds import check_bounds
from offroadbench.config import check_choice, check_int, check_range

__all__ = ["GridConfig", "QUANTISE_MODES"]

#: ``png16``: heights snapped to 65,535 levels over the relief (the default); ``none``: float64 as generated
QUANTISE_MODES = ("png16", "none")


@dataclass(frozen=True, kw_only=True)
class GridConfig:
    """A regular square-cell grid. Defaults: the paper's 1009 x 1009 at 5 cm (Majhor & Bos 2023, Sec. 2.1)."""

    rows: int = 1009
    """Number of samples along y."""
    cols: int = 1009
    """Number of samples along x."""
    cell_size_m: float = 0.05
    """Distance between neighbouring samples, metres."""
    quantise: str = "png16"
    """What the finished terrain's heights are. ``png16`` (default): snapped to the 65,535 levels of
    a 16-bit PNG over the terrain's relief (:func:`offroadbench.levels16.quantise`; a step of 59 um
    on the paper's 3.84 m), which is what Majhor & Bos (2023, Sec. 2.2) exported and drove on, and
    which is bit-identical on every x86-64 CPU; ``generate -o x.png`` then ``drive x.png`` meets the
    same terrain as ``drive PRESET``. ``none``: the float64 heights as generated, whose last bits
    depend on the CPU's SIMD and BLAS kernels (same-machine determinism only)."""

    def __post_init__(self) -> None:
        check_int(self, "rows", self.rows, lo=3)
        check_int(self, "cols", self.cols, lo=3)
        check_range(self, "cell_size_m", self.cell_size_m, lo=0, lo_open=True)
        check_bounds(self, "GridConfig")  # a physical grid spacing (offroadbench.bounds.CELL_SIZE)
        check_choice(self, "quantise", self.quantise, QUANTISE_MODES)

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (self.rows, self.cols)

    @property
    def width_m(self) -> float:
        """Extent along x from the first to the last sample, metres."""
        return (self.cols - 1) * self.cell_size_m

    @property
    def height_m(self) -> float:
        """Extent along y from the first to the last sample, metres."""
        return (self.rows - 1) * self.cell_size_m
