"""Multifractal terrain: the pixel-wise product of three W-M DEMs, Majhor & Bos 2023, Sec. 2.1, Table 1.

Each of the low / mid / high-frequency W-M surfaces (M = 16 / 32 / 64, D = 2.2 / 2.45 / D_high,
G = 1e-6 / 8e-8 / 1e-8, gamma = 1.5, L = 100.9, n_max = grid length, phases in [0, pi]) is

1. evaluated with Eq. (1)-(2) (:mod:`offroadbench.terrain.fractal.wm`),
2. low-pass filtered with a Gaussian (sigma ``wm.smoothing_sigma_px``),
3. brought to zero mean and the same range (divided by its largest absolute value, so it lies in
   [-1, 1] with at least one sample at +-1),

then the three are multiplied pixel-wise and the product is scaled to ``relief_m`` (min 0).
Because every layer is rescaled, A and G do not change the result (kept for fidelity).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register
from offroadbench.terrain.fractal.wm import WMConfig, draw_phases, gaussian_smooth, wm_surface

__all__ = ["MultifractalConfig", "layer_configs", "normalise_layer", "generate_multifractal"]

LAYER_NAMES = ("low", "mid", "high")


#: The W-M settings Table 1 gives for all three DEMs (gamma = 1.5, L = 100.9, phases in [0, pi],
#: x and y in pixels: the WMConfig defaults), low-pass filtered with sigma 0.5 px.
PAPER_WM = WMConfig(smoothing_sigma_px=0.5)

#: Fields of the shared W-M config that each DEM sets itself (MultifractalConfig.M, .D_*, .G).
PER_LAYER = ("M", "D", "G")


@dataclass(frozen=True, kw_only=True)
class MultifractalConfig:
    """Paper multifractal DEM. Defaults: Table 1 with D_high = 2.45.

    The three W-M DEMs are ``dataclasses.replace(wm, M=M[i], D=D_i, G=G[i])``: they share every
    setting of ``wm`` and differ by the ridges, the fractal dimension and G (:func:`layer_configs`).
    """

    wm: WMConfig = field(default_factory=lambda: PAPER_WM)
    """W-M settings shared by the three DEMs (TOML table ``[layers.NAME.wm]``); its M, D and G
    are not used (each DEM takes them from the fields below).

    ``wm.smoothing_sigma_px`` is the Gaussian low-pass of each DEM. The paper names a low-pass
    Gaussian but not its size; 0.5 px with a 3 x 3 kernel is the default of MATLAB's
    ``imgaussfilt``, the most likely tool of the original pipeline: a choice, not a fit (README,
    "Interpretation choices", shows how the result moves with it)."""
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
    relief_m: float = 3.84
    """Relief (max - min) of the product, metres: the paper's 16-bit range at Unreal Z scale 0.75."""

    def __post_init__(self) -> None:
        if len(self.M) != 3 or len(self.G) != 3:
            raise InputError("MultifractalConfig.M and .G must each list 3 values (low, mid, high)")
        unused = WMConfig()
        for name in PER_LAYER:
            if getattr(self.wm, name) != getattr(unused, name):
                raise InputError(
                    f"MultifractalConfig.wm.{name} = {getattr(self.wm, name)!r} is not used: each DEM sets "
                    f"{name} itself; use {'D_low, D_mid, D_high' if name == 'D' else name + ' = [low, mid, high]'}"
                )
        for i in range(3):
            check_int(self, f"M[{i}]", self.M[i], lo=1)
            check_range(self, f"G[{i}]", self.G[i], lo=0, lo_open=True)
        for name in ("D_low", "D_mid", "D_high"):
            check_range(self, name, getattr(self, name), lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "relief_m", self.relief_m, lo=0, lo_open=True)

    def describe(self, grid: GridConfig) -> str:
        """The evaluated terms of each W-M layer on ``grid``, on one line."""
        return "; ".join(f"{name}: {c.describe(grid)}" for name, c in zip(LAYER_NAMES, layer_configs(self), strict=True))


def layer_configs(cfg: MultifractalConfig) -> tuple[WMConfig, WMConfig, WMConfig]:
    """The three W-M configs (low, mid, high frequency) of Table 1."""
    dims = (cfg.D_low, cfg.D_mid, cfg.D_high)
    return tuple(dataclasses.replace(cfg.wm, M=cfg.M[i], D=dims[i], G=cfg.G[i]) for i in range(3))  # type: ignore[return-value]


def normalise_layer(z: np.ndarray) -> np.ndarray:
    """Zero mean and unit largest absolute value: 'the same range and zero mean' of Sec. 2.1."""
    z = z - z.mean()
    peak = np.abs(z).max()
    return z / peak if peak > 0 else z


def multifractal_layers(cfg: MultifractalConfig, grid: GridConfig, rng: np.random.Generator) -> list[np.ndarray]:
    """The three filtered, normalised W-M layers (low, mid, high). One child RNG per layer."""
    children = rng.spawn(3)
    out = []
    for wcfg, child in zip(layer_configs(cfg), children, strict=True):
        z = gaussian_smooth(wm_surface(wcfg, grid, draw_phases(wcfg, grid, child)), wcfg.smoothing_sigma_px)
        out.append(normalise_layer(z))
    return out


@register("multifractal", MultifractalConfig, summary="product of three W-M DEMs (Majhor & Bos 2023, Sec. 2.1, Table 1)")
def generate_multifractal(cfg: MultifractalConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """Multifractal DEM: product of the three normalised W-M layers, scaled to ``relief_m``."""
    low, mid, high = multifractal_layers(cfg, grid, rng)
    product = low * mid * high
    return Heightmap(z=product, cell_size_m=grid.cell_size_m).rescaled(cfg.relief_m)

