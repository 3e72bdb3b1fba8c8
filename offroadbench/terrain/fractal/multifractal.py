"""Multifractal terrain: the pixel-wise product of three W-M DEMs, Majhor & Bos 2023, Sec. 2.1, Table 1.

Each of the low / mid / high-frequency W-M surfaces (M = 16 / 32 / 64, D = 2.2 / 2.45 / D_high,
G = 1e-6 / 8e-8 / 1e-8, gamma = 1.5, L = 100.9, n_max = grid length, phases in [0, pi]) is

1. evaluated with Eq. (1)-(2) (:mod:`offroadbench.terrain.fractal.wm`),
2. low-pass filtered with a Gaussian (sigma ``smoothing_sigma_px``),
3. brought to zero mean and the same range (divided by its largest absolute value, so it lies in
   [-1, 1] with at least one sample at +-1),

then the three are multiplied pixel-wise and the product is scaled to ``relief_m`` (min 0).
Because every layer is rescaled, A and G do not change the result (kept for fidelity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.registry import register
from offroadbench.terrain.fractal.wm import WMConfig, draw_phases, gaussian_smooth, wm_surface

__all__ = ["MultifractalConfig", "layer_configs", "normalise_layer", "generate_multifractal"]

LAYER_NAMES = ("low", "mid", "high")


@dataclass(frozen=True, kw_only=True)
class MultifractalConfig:
    """Paper multifractal DEM. Defaults: Table 1 with D_high = 2.45, 1009 x 1009 at 0.05 m."""

    rows: int = 1009
    """Grid rows."""
    cols: int = 1009
    """Grid columns."""
    cell_size_m: float = 0.05
    """Grid spacing, metres (paper: 5 cm per pixel after the Unreal XY scale)."""
    M: tuple[int, int, int] = (16, 32, 64)
    """Ridges of the low, mid, high-frequency DEMs."""
    D_low: float = 2.2
    """Fractal dimension of the low-frequency DEM."""
    D_mid: float = 2.45
    """Fractal dimension of the mid-frequency DEM."""
    D_high: float = 2.45
    """Fractal dimension of the high-frequency DEM: the paper's control knob (2.3, 2.45, 2.6)."""
    G: tuple[float, float, float] = (1e-6, 8e-8, 1e-8)
    """Elevation scaling coefficients of the three DEMs (Eq. 2)."""
    gamma: float = 1.5
    """Frequency density (all three DEMs)."""
    L: float = 100.9
    """Sampling length (all three DEMs), in the units of ``coordinates``."""
    n_max: int | None = None
    """Highest frequency index; None = grid length in pixels (paper: 1009)."""
    phase_min: float = 0.0
    """Random phase range start, radians."""
    phase_max: float = math.pi
    """Random phase range end, radians."""
    coordinates: str = "pixels"
    """What x, y of Eq. (1) are measured in (see offroadbench.terrain.fractal.wm.COORDINATES)."""
    amplitude_tol: float = 1e-6
    """Drop W-M terms below this fraction of the first term's amplitude."""
    band_limited: bool = False
    """Drop W-M terms above the grid's Nyquist frequency (anti-aliased variant; not the paper)."""
    smoothing_sigma_px: float = 0.5
    """Gaussian low-pass sigma, pixels, applied to each W-M DEM.

    The paper names a low-pass Gaussian but not its size. 0.5 px with a 3 x 3 kernel is the
    default of MATLAB's ``imgaussfilt``, the most likely tool of the original pipeline; it is a
    choice, not a fit (README, "Interpretation choices", shows how the result moves with it)."""
    origin_offset_px: float = 0.0
    """Origin of Eq. (1) this many pixels outside the first corner (0 = the paper's reading).
    An option beyond the paper: moves the coherent extreme of [0, pi]-phase W-M sums off the map
    (see WMConfig.origin_offset_px)."""
    relief_m: float = 3.84
    """Relief (max - min) of the product, metres: the paper's 16-bit range at Unreal Z scale 0.75."""

    def __post_init__(self) -> None:
        check_int(self, "rows", self.rows, lo=3)
        check_int(self, "cols", self.cols, lo=3)
        check_range(self, "cell_size_m", self.cell_size_m, lo=0, lo_open=True)
        if len(self.M) != 3 or len(self.G) != 3:
            from offroadbench.errors import InputError

            raise InputError("MultifractalConfig.M and .G must each list 3 values (low, mid, high)")
        for i, m in enumerate(self.M):
            check_int(self, f"M[{i}]", m, lo=1)
        for name in ("D_low", "D_mid", "D_high"):
            check_range(self, name, getattr(self, name), lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "gamma", self.gamma, lo=1, lo_open=True)
        check_range(self, "L", self.L, lo=0, lo_open=True)
        check_range(self, "relief_m", self.relief_m, lo=0, lo_open=True)
        check_range(self, "smoothing_sigma_px", self.smoothing_sigma_px, lo=0)
        # the remaining fields are checked by WMConfig for each layer
        layer_configs(self)

    def describe(self) -> str:
        """The evaluated terms of each W-M layer, on one line."""
        return "; ".join(f"{name}: {c.describe()}" for name, c in zip(LAYER_NAMES, layer_configs(self)))


def layer_configs(cfg: MultifractalConfig) -> tuple[WMConfig, WMConfig, WMConfig]:
    """The three W-M configs (low, mid, high frequency) of Table 1."""
    dims = (cfg.D_low, cfg.D_mid, cfg.D_high)
    return tuple(
        WMConfig(
            rows=cfg.rows,
            cols=cfg.cols,
            cell_size_m=cfg.cell_size_m,
            M=cfg.M[i],
            n_max=cfg.n_max,
            gamma=cfg.gamma,
            D=dims[i],
            L=cfg.L,
            G=cfg.G[i],
            phase_min=cfg.phase_min,
            phase_max=cfg.phase_max,
            coordinates=cfg.coordinates,
            amplitude_tol=cfg.amplitude_tol,
            band_limited=cfg.band_limited,
            smoothing_sigma_px=cfg.smoothing_sigma_px,
            origin_offset_px=cfg.origin_offset_px,
        )
        for i in range(3)
    )  # type: ignore[return-value]


def normalise_layer(z: np.ndarray) -> np.ndarray:
    """Zero mean and unit largest absolute value: 'the same range and zero mean' of Sec. 2.1."""
    z = z - z.mean()
    peak = np.abs(z).max()
    return z / peak if peak > 0 else z


def multifractal_layers(cfg: MultifractalConfig, rng: np.random.Generator) -> list[np.ndarray]:
    """The three filtered, normalised W-M layers (low, mid, high). One child RNG per layer."""
    children = rng.spawn(3)
    out = []
    for wcfg, child in zip(layer_configs(cfg), children):
        z = gaussian_smooth(wm_surface(wcfg, draw_phases(wcfg, child)), wcfg.smoothing_sigma_px)
        out.append(normalise_layer(z))
    return out


@register("multifractal", MultifractalConfig, summary="product of three W-M DEMs (Majhor & Bos 2023, Sec. 2.1, Table 1)")
def generate_multifractal(cfg: MultifractalConfig, rng: np.random.Generator) -> Heightmap:
    """Multifractal DEM: product of the three normalised W-M layers, scaled to ``relief_m``."""
    low, mid, high = multifractal_layers(cfg, rng)
    product = low * mid * high
    return Heightmap(z=product, cell_size_m=cfg.cell_size_m).rescaled(cfg.relief_m)

