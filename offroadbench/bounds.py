"""Physical bounds of the soil and vehicle parameters, each with the source of its range.

A config's own checks (``__post_init__``) say what the code can compute with (a positive radius,
``n > 0``); these bounds say what a real soil or a real wheeled vehicle can be. A value outside
them is not a soil or a vehicle but a typing slip (``k_phi = 8.2e60`` for ``8.2e5``), and a
simulation of it is no trial: an absurdly stiff soil throws the vehicle metres up while it
settles. Each range is wide (about ten times beyond the extreme values its source lists, where it
lists values) so that every real soil and vehicle passes; a value outside is refused with one
line naming the field, the value, the range and its source.

Keyed by config class name, then field name (:data:`BOUNDS`); :func:`check_bounds` is called at
the end of the configs' ``__post_init__``. Fields a table does not list are left to the config's
own checks. The settings reference (``docs/reference.md``) prints every range with its source.

A trial whose vehicle is thrown while it settles anyway (a combination of legal values) is a fault,
not an outcome: :func:`check_settled` raises :class:`offroadbench.errors.TrialFault`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from offroadbench.errors import InputError, TrialFault

__all__ = ["BOUNDS", "CELL_SIZE", "HEIGHT_M", "Bound", "check_heights", "SETTLE_MAX_RISE_M", "SETTLE_MAX_SPEED_M_S", "check_bounds", "check_settled",
           "reference_lines"]

_WONG = "Wong 2001, Theory of Ground Vehicles, 3rd ed., Table 2.3"


@dataclass(frozen=True)
class Bound:
    """A closed range [lo, hi] (an open end where ``lo_open``/``hi_open``) and its source."""

    lo: float
    hi: float
    source: str
    lo_open: bool = False

    def text(self) -> str:
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"

    def holds(self, value: float) -> bool:
        above = value > self.lo if self.lo_open else value >= self.lo
        return above and value <= self.hi


#: the grid spacing of any terrain map, metres: from lab-scale scans to coarse planetary DEMs
CELL_SIZE = Bound(1e-5, 1e5, "lab terrain scans (tens of micrometres) to global planetary DEMs (MOLA MEGDR: "
                             "463 m)")

#: the height of any terrain sample, metres (the Solar System's largest relief is about 22 km above
#: its datum: Olympus Mons on Mars, MOLA; a Heightmap of 1e12 m spikes is a unit or file error)
HEIGHT_M = Bound(-1e5, 1e5, "the largest relief in the Solar System, Olympus Mons, is about 22 km above the Mars "
                            "datum (MOLA); Earth's Mariana Trench is 11 km deep")


def check_heights(z_min_m: float, z_max_m: float, where: str = "heightmap") -> None:
    """Refuse (one line) heights outside :data:`HEIGHT_M`: no terrain has them, and no engine can
    represent them (PyBullet's float32 heightfield loses the map's range)."""
    for name, value in (("lowest height", z_min_m), ("highest height", z_max_m)):
        if not HEIGHT_M.holds(float(value)):
            raise InputError(f"{where}: {name} {value:g} m is outside the physical range {HEIGHT_M.text()} m "
                             f"({HEIGHT_M.source}); check the heights and their unit")


#: config class name -> field -> physical range and its source
BOUNDS: Mapping[str, Mapping[str, Bound]] = {
    "GridConfig": {"cell_size_m": CELL_SIZE},
    "Heightmap": {"cell_size_m": CELL_SIZE},
    "SoilParams": {
        "n": Bound(0.05, 2.0, f"{_WONG}: n from 0.13 (heavy clay) to 1.6 (snow)"),
        "k_c": Bound(-1e6, 1e6, f"{_WONG}: 0.99 (dry sand) to 102 kN/m^(n+1) (LETE sand); ten times that either way "
                                "(a fitted intercept)"),
        "k_phi": Bound(0.0, 5e7, f"{_WONG}: 196.7 (snow) to 5301 kN/m^(n+2) (LETE sand); about ten times that"),
        "cohesion_pa": Bound(0.0, 1e5, f"{_WONG}: 1.03 kPa (snow) to 68.95 kPa (heavy clay)"),
        "friction_angle_deg": Bound(0.0, 60.0, f"{_WONG}: 13 to 34 deg; dense lunar regolith up to about 50 deg "
                                               "(Carrier, Olhoeft & Mendell 1991, Lunar Sourcebook, ch. 9)"),
        "shear_modulus_m": Bound(1e-4, 0.2, "Wong 2001, Sec. 2.5: 0.6 cm (clay at maximum compaction) to 2.5 cm "
                                            "(loose sand, fresh snow); Ishigami et al. 2007: 3.6 cm", lo_open=True),
        "lateral_shear_modulus_m": Bound(1e-4, 0.2, "as shear_modulus_m (Ishigami et al. 2007: k_y 2.0 cm)",
                                         lo_open=True),
        "a0": Bound(0.0, 1.0, "Wong & Reece 1967: c1 0.18 (clay) to 0.43 (sand); Ishigami et al. 2007: 0.4",
                    lo_open=True),
        "a1": Bound(0.0, 1.0, "Wong & Reece 1967: c2 0.32; Ishigami et al. 2007: 0.15"),
    },
    "VehicleSpec": {
        "wheel_radius_m": Bound(0.01, 2.0, "small robots (Jackal 0.098 m, Husky 0.165 m) to the largest haul-truck "
                                           "tyres (59/80R63, about 4 m across)", lo_open=True),
        "wheel_width_m": Bound(0.005, 2.0, "as wheel_radius_m (59/80R63: 1.5 m wide)", lo_open=True),
        "track_m": Bound(0.05, 10.0, "small robots (Jackal 0.37 m) to haul trucks (about 7 m)", lo_open=True),
        "max_speed_m_s": Bound(0.0, 60.0, "fast off-road vehicles reach about 40 m/s", lo_open=True),
        "max_accel_m_s2": Bound(0.0, 20.0, "traction limits acceleration to about mu g with mu below 1.5 "
                                           "on any ground (wheel_friction)", lo_open=True),
        "max_jerk_m_s3": Bound(0.0, 1000.0, "two orders of magnitude above road-vehicle comfort limits "
                                            "(about 2-10 m/s^3)", lo_open=True),
        "max_yaw_rate_rad_s": Bound(0.0, 20.0, "a skid-steer robot turning in place at top speed: 2 v / track, "
                                               "below 10 rad/s for the vehicles above", lo_open=True),
        "wheel_torque_limit_nm": Bound(0.0, 1e6, "small robots (Husky 28 N m) to haul-truck wheel motors "
                                                 "(hundreds of kN m)", lo_open=True),
        "wheel_friction": Bound(0.0, 3.0, "peak tyre-road adhesion is about 0.1 (ice) to 0.9 (dry asphalt) "
                                          "(Wong 2001, ch. 1); racing tyres reach about 1.7", lo_open=True),
        "chassis_friction": Bound(0.0, 3.0, "as wheel_friction"),
        "tyre_stiffness_n_m": Bound(0.0, 1e8, "tyre vertical stiffness: about 1e5 N/m (cars) to 1e7 N/m (haul "
                                              "trucks); rigid wheels need no figure", lo_open=True),
        "tyre_damping_n_s_m": Bound(0.0, 1e7, "about critical damping of the stiffest tyre above"),
        "wheel_spin_inertia_kg_m2": Bound(0.0, 1e5, "Husky 1 kg m^2 (with the drive train) to haul-truck wheels "
                                                    "(thousands of kg m^2)", lo_open=True),
        "skid_track_factor": Bound(1.0, 5.0, "the shipped vehicles' controllers use 1.5 (Jackal) and 1.875 "
                                             "(Husky) as wheel_separation_multiplier"),
    },
}


def check_bounds(cfg: Any, where: str | None = None) -> None:
    """Refuse (InputError, one line) a field of ``cfg`` outside its physical range (:data:`BOUNDS`)."""
    table = BOUNDS.get(type(cfg).__name__)
    if not table:
        return
    label = where or f"{type(cfg).__name__} {getattr(cfg, 'name', '')!r}".rstrip(" '")
    for name, bound in table.items():
        value = getattr(cfg, name, None)
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        if not (math.isfinite(value) and bound.holds(float(value))):
            raise InputError(f"{label}: {name} = {value:g} is outside the physical range {bound.text()} "
                             f"({bound.source}); check the value and its unit")


#: a vehicle whose base rises more than this above the terrain near its spawn point while it
#: settles, or ...
SETTLE_MAX_RISE_M = 2.0
#: ... moves faster than this at the end of the settling, was thrown: a fault, not a trial
SETTLE_MAX_SPEED_M_S = 5.0


def check_settled(position_m, velocity_m_s, ground_z_m: float, size_m: float = 0.0, where: str = "") -> None:
    """Raise TrialFault if a vehicle just settled (wheels braked, ``sim.settle_time_s``) was thrown:
    its base more than ``SETTLE_MAX_RISE_M + size_m`` (``size_m``: the vehicle's own height scale)
    above ``ground_z_m`` (the highest terrain near its spawn point) or moving faster than
    ``SETTLE_MAX_SPEED_M_S``. A vehicle at rest on any legal ground does
    neither; a soil or contact far outside physical bounds does (issue 30)."""
    x, y, z = (float(v) for v in position_m[:3])
    speed = math.sqrt(sum(float(v) ** 2 for v in velocity_m_s[:3]))
    rise = z - float(ground_z_m)
    max_rise = SETTLE_MAX_RISE_M + float(size_m)
    if not (math.isfinite(rise) and math.isfinite(speed)) or rise > max_rise or speed > SETTLE_MAX_SPEED_M_S:
        raise TrialFault(f"{where + ': ' if where else ''}the vehicle was thrown while it settled (base {rise:.3g} m "
                         f"above the ground near its spawn point, moving at {speed:.3g} m/s after settling; at rest it "
                         f"is within {max_rise:.3g} m and {SETTLE_MAX_SPEED_M_S:g} m/s): the soil or vehicle "
                         "is outside physical bounds")


def reference_lines() -> list[str]:
    """The settings reference's section of physical bounds, one table per config (Markdown)."""
    lines = ["## Physical bounds", "",
             ("Soil (`soils/*.toml`, `[soil]`) and vehicle (`vehicle.toml`, `[vehicle]`) values outside these "
              "ranges are refused (offroadbench.bounds): they are wide enough for every real soil and vehicle, "
              "and each cites the range it comes from."), ""]
    for cls, table in BOUNDS.items():
        lines += [f"### `{cls}`", "", "| key | physical range | source |", "|---|---|---|"]
        lines += [f"| `{name}` | {b.text()} | {b.source} |" for name, b in table.items()]
        lines.append("")
    lines += [f"Terrain heights (`Heightmap.z`, every map read or generated): {HEIGHT_M.text()} m ({HEIGHT_M.source}).", ""]
    return lines
