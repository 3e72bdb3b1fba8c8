"""Figures of the surface statistics of :mod:`offroadbench.analysis.surface`.

Like :mod:`offroadbench.plots.terrain`, functions return a matplotlib Figure; the caller (the CLI)
saves it.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from offroadbench.analysis.surface import (
    cumulative_counts,
    cumulative_slope_distribution,
    fit_sfd_slope,
    fit_spectral_slope,
    horn_slope_deg,
    radial_power_spectrum,
)
from offroadbench.heightmap import Heightmap
from offroadbench.plots.style import CLASS_COLOURS

__all__ = ["plot_surface_analysis"]


def plot_surface_analysis(hm: Heightmap, crater_diameters_m=None, title: str = ""):
    """Cumulative slope distribution (Horn, Martin et al. 2014, Fig. 11) and radial PSD with its fit (Martin et al. 2014, Fig. 14).

    With ``crater_diameters_m`` a third panel shows the cumulative size-frequency curve and the
    fitted power-law slope (Martin et al. 2014, Eq. 12).
    """
    panels = 3 if crater_diameters_m is not None and len(crater_diameters_m) >= 2 else 2
    fig = Figure(figsize=(5.0 * panels, 4.2), layout="tight")
    axes = fig.subplots(1, panels)

    angles, frac = cumulative_slope_distribution(horn_slope_deg(hm))
    ax = axes[0]
    keep = frac > 0
    ax.semilogy(angles[keep], 100.0 * frac[keep], color=CLASS_COLOURS[0])
    ax.set_xlabel("slope angle (deg)")
    ax.set_ylabel("area steeper than angle (%)")
    ax.set_title("cumulative slope distribution (Horn)")
    ax.grid(True, which="both", alpha=0.3)

    spec = radial_power_spectrum(hm)
    fit = fit_spectral_slope(spec)
    ax = axes[1]
    ax.loglog(spec.frequency_per_m, spec.power, ".", color="#444444", label="radially averaged PSD")
    f = np.geomspace(fit.f_min_per_m, fit.f_max_per_m, 20)
    ax.loglog(f, 10**fit.intercept * f ** (-fit.beta), "-", color="#d62728",
              label=f"fit: beta = {fit.beta:.2f}, D = {fit.dimension:.2f}")
    ax.set_xlabel("spatial frequency (cycles/m)")
    ax.set_ylabel("power")
    ax.set_title("power spectrum")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)

    if panels == 3:
        d, n = cumulative_counts(crater_diameters_m)
        k = fit_sfd_slope(d)
        ax = axes[2]
        ax.loglog(d, n, ".", color="#444444", label="placed craters")
        dd = np.geomspace(d.min(), d.max(), 20)
        ax.loglog(dd, n[-1] * (dd / d.min()) ** (-k), "-", color="#d62728", label=f"fit: k = {k:.2f}")
        ax.set_xlabel("diameter D (m)")
        ax.set_ylabel("craters with diameter >= D")
        ax.set_title("crater size-frequency")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)

    if title:
        fig.suptitle(title)
    return fig
