"""The papers this package implements, cited in docstrings by author and year.

A docstring that says "Martin et al. 2014, Eq. 12" means equation 12 of the entry keyed
``martin2014`` below. :data:`REFERENCES` maps each key to the full citation; ``offroadbench
terrains`` and the reports name presets and methods by these keys.
"""

from __future__ import annotations

__all__ = ["REFERENCES"]

#: key -> (short form used in docstrings, full citation)
REFERENCES: dict[str, tuple[str, str]] = {
    "majhor2023": (
        "Majhor & Bos 2023",
        "C. D. Majhor and J. P. Bos, \"Multifractal Terrain Generation for Evaluating Autonomous "
        "Off-Road Ground Vehicles\", Robust Autonomous Systems Laboratory, Michigan Technological "
        "University, 2023 (arXiv preprint). The 3D Weierstrass-Mandelbrot terrain (Eq. 1-2, Table 1), "
        "the multifractal product, the Moore-gradient roughness classes (Eq. 3-4), missions, "
        "failure rules, metrics (Eq. 5) and the D = 2.3 / 2.45 / 2.6 study (Sec. 3).",
    ),
    "martin2014": (
        "Martin et al. 2014",
        "I. Martin, S. Parkes and M. Dunstan, \"Modeling cratered surfaces with real and synthetic "
        "terrain for testing planetary landers\", IEEE Transactions on Aerospace and Electronic "
        "Systems 50(4), 2916-2928, 2014. doi:10.1109/TAES.2014.120282. Crater profile (Eq. 1-10), "
        "degradation by age (Eq. 11), size-frequency distribution (Eq. 12), RMD fractal expansion "
        "(Eq. 13-16), gap filling (Sec. IV.B).",
    ),
    "yoshikawa2001": (
        "Yoshikawa & Nishiguchi 2001",
        "S. Yoshikawa and K. Nishiguchi, \"Generation of Digital Elevation Map of the Moon from "
        "Observation Data Interpolated by Fractal Modeling\", Transactions of the SICE 37(3), "
        "262-267, 2001. fBm by Fourier filtering (Eq. 3-7), spectral restoration (Sec. 3.4), "
        "kth-largest crater diameters (Eq. 8-9), three-part crater profile (Eq. 10-11).",
    ),
    "li2022": (
        "Li et al. 2022",
        "X. Li, J.-B. Vincent, R. Weller and G. Zachmann, \"Numerical approach to synthesizing "
        "realistic asteroid surfaces from morphological parameters\", Astronomy & Astrophysics, "
        "2022 (accepted 29 November 2021). Crater kernels 1-4 (Eq. 3-16), power-law inversion "
        "sampling of diameters per size bin (Eq. 17-21).",
    ),
    "parkes1999": (
        "Parkes & Martin 1999",
        "S. M. Parkes and I. Martin, \"Virtual Lunar Landscapes for Testing Vision-Guided Lunar "
        "Landers\", University of Dundee, work under ESA contract 12821/98/NL/MV (the text carries "
        "no date; 1999 is inferred from the contract). Crater bowl + ejecta model, fractal zones, "
        "ageing by rim rounding, crater files kept apart from the elevation model.",
    ),
}

