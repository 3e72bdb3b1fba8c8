"""Soils as data: a soil's parameters (:class:`SoilParams`, the ``[soil]`` table of ``soils/*.toml``),
finding and loading soil files, and the published slip-sinkage bands shipped beside them
(``soils/data/slip-sinkage-*.csv``). The force law that uses them is
offroadbench.sim.tyre_laws.terramechanics."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from offroadbench import resources
from offroadbench.bounds import check_bounds
from offroadbench.config import check_range, from_dict, load_toml
from offroadbench.errors import InputError
from offroadbench.registry import unknown_name

__all__ = ["DEFAULT_SOIL", "SlipSinkageBand", "SoilParams", "list_soils", "load_soil", "published_slip_sinkage",
           "soil_files"]

#: the soil of a terramechanics trial when neither the study nor the terrain names one
DEFAULT_SOIL = "lunar-regolith"


@dataclass(frozen=True, kw_only=True)
class SoilParams:
    """A soil's Bekker, Mohr-Coulomb and Janosi-Hanamoto parameters, SI units (``soils/*.toml``)."""

    name: str
    """Short name, e.g. ``lunar-regolith``."""
    description: str = ""
    """What the soil is and where its numbers come from."""
    n: float
    """Bekker's sinkage exponent, dimensionless."""
    k_c: float
    """Bekker's cohesive modulus, N/m^(n+1)."""
    k_phi: float
    """Bekker's frictional modulus, N/m^(n+2)."""
    cohesion_pa: float
    """Mohr-Coulomb cohesion c, Pa."""
    friction_angle_deg: float
    """Mohr-Coulomb internal friction angle phi, degrees."""
    shear_modulus_m: float
    """Janosi-Hanamoto shear deformation modulus K (longitudinal), m."""
    lateral_shear_modulus_m: float
    """Shear deformation modulus K_y for the lateral force (Ishigami et al. 2007), m."""
    a0: float = 0.4
    """theta_m = (a0 + a1 |s|) theta_1 (Wong & Reece 1967); Ishigami et al. 2007 use 0.4."""
    a1: float = 0.15
    """See a0; Ishigami et al. 2007 use 0.15."""
    n1: float = 0.0
    """Slip-sinkage: the sinkage exponent grows with slip, ``n(s) = n + n1 |s|`` (Ding et al. 2011,
    their slip-dependent ``N = n0 + n1 s``), so a spinning wheel sinks deeper; 0: no slip-sinkage.
    Dimensionless. A value above 0 must name its published source in ``n1_source``."""
    n1_source: str = ""
    """Where ``n1`` comes from: author, year, and the page, table or equation of its tabulated value
    (required when ``n1 > 0``; a value fitted to this project's own checks is not a source)."""

    def __post_init__(self) -> None:
        check_range(self, "n", self.n, lo=0, lo_open=True, hi=3)
        check_range(self, "k_c", self.k_c, lo=None)
        check_range(self, "k_phi", self.k_phi, lo=None)
        check_range(self, "cohesion_pa", self.cohesion_pa, lo=0)
        check_range(self, "friction_angle_deg", self.friction_angle_deg, lo=0, hi=60)
        check_range(self, "shear_modulus_m", self.shear_modulus_m, lo=0, lo_open=True)
        check_range(self, "lateral_shear_modulus_m", self.lateral_shear_modulus_m, lo=0, lo_open=True)
        check_range(self, "a0", self.a0, lo=0, lo_open=True, hi=1)
        check_range(self, "a1", self.a1, lo=0, hi=1)
        check_range(self, "n1", self.n1, lo=0, hi=2)
        if self.n1 > 0.0 and not self.n1_source.strip():
            raise InputError(f"soil {self.name!r}: n1 = {self.n1:g} needs n1_source (author, year, page or table "
                             "of the published value); without one, n1 = 0")
        if self.a0 + self.a1 >= 1.0:
            raise InputError(f"soil {self.name!r}: a0 + a1 = {self.a0 + self.a1:g} must be below 1 (theta_m < theta_1)")
        check_bounds(self, f"soil {self.name!r}")  # physical ranges with their sources (offroadbench.bounds)

    def exponent(self, slip):
        """The sinkage exponent at slip ``s``: ``n + n1 |s|`` (Ding et al. 2011), dimensionless."""
        return self.n + self.n1 * np.abs(slip)

    def modulus(self, width_m: float) -> float:
        """Bekker's ``k_c / b + k_phi`` for a wheel of width ``b``, N/m^(n+2); must be positive."""
        return self.k_c / width_m + self.k_phi


def soil_files() -> dict[str, Path]:
    """{soil name: TOML path} of every ``soils/<name>.toml`` on the search path and shipped."""
    return resources.soil_files()


def list_soils() -> list[str]:
    """Names of every known soil."""
    return list(soil_files())


def load_soil(name_or_path: str | Path) -> SoilParams:
    """A soil by name (``lunar-regolith``) or by the path of its TOML (a ``[soil]`` table)."""
    text = str(name_or_path)
    path = Path(text)
    if not (text.endswith(".toml") or path.is_file()):
        found = soil_files()
        if text not in found:
            raise unknown_name("soil", text, found, extra="(or give the path of a soil .toml)")
        path = found[text]
    data = load_toml(path)
    if not isinstance(data.get("soil"), dict):
        raise InputError(f"{path}: no [soil] table")
    table = dict(data["soil"])
    table.setdefault("name", path.stem)
    return from_dict(SoilParams, table, where=f"{path} [soil]")


@dataclass(frozen=True, kw_only=True)
class SlipSinkageBand:
    """A published band of sinkage at a slip relative to the static sinkage (``soils/data/*.csv``)."""

    slip: float
    ratio_low: float
    """Lowest published sinkage(slip) / sinkage(0)."""
    ratio_high: float
    """Highest published sinkage(slip) / sinkage(0)."""
    wheel: str
    soil: str
    """The soil the source tested (its own words)."""
    source: str
    figure: str
    applies_to: tuple[str, ...] = ()
    """Names of the soils (``soils/*.toml``) of the kind the source tested, beside which ``soil check``
    shows the band."""


def published_slip_sinkage(soil_name: str | None = None) -> list[SlipSinkageBand]:
    """The published single-wheel slip-sinkage bands shipped in ``soils/data/slip-sinkage-*.csv``
    (each file's header names its source, figure and tolerance); with ``soil_name``, only those
    whose ``applies_to`` names that soil."""
    import csv

    out = []
    folder = resources.shipped("soils") / "data"
    for path in sorted(folder.glob("slip-sinkage-*.csv")) if folder.is_dir() else []:
        lines = [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
        for row in csv.DictReader(lines):
            band = SlipSinkageBand(slip=float(row["slip"]), ratio_low=float(row["ratio_low"]),
                                   ratio_high=float(row["ratio_high"]), wheel=row["wheel"], soil=row["soil"],
                                   source=row["source"], figure=row["figure"],
                                   applies_to=tuple(row["applies_to"].split()))
            if soil_name is None or soil_name in band.applies_to:
                out.append(band)
    return out
