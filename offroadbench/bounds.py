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

The model file a ``vehicle.toml`` names (its URDF) is bounded too (:data:`URDF_BOUNDS`,
:func:`check_urdf`, called when the vehicle is loaded: offroadbench.sim.trial.vehicle.load_vehicle):
every link's mass, its inertia tensor (positive definite, a real body's, within range), its
collision shapes' sizes, and the joints' origins, axes and limits. A chassis of mass 0 is not a
vehicle (PyBullet pins a massless base to the world: every trial ``stuck``), nor one of 1e9 kg.

A trial whose vehicle is thrown while it settles anyway (a combination of legal values) is a fault,
not an outcome: :func:`check_settled` raises :class:`offroadbench.errors.TrialFault`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from offroadbench.errors import InputError, TrialFault

__all__ = ["BOUNDS", "CELL_SIZE", "HEIGHT_M", "URDF_BOUNDS", "Bound", "check_heights", "SETTLE_MAX_RISE_M",
           "SETTLE_MAX_SPEED_M_S", "check_bounds", "check_settled", "check_urdf", "reference_lines"]

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


#: a URDF's physical quantities (the model file of a vehicle.toml): name -> (unit, range and its source)
URDF_BOUNDS: Mapping[str, tuple[str, Bound]] = {
    "mass": ("kg", Bound(1e-6, 1e6, "a milligram (robot descriptions give bare frames 1e-5 to 1e-3 kg) to a "
                                    "loaded haul truck's frame (CAT 797F: 623 t gross)")),
    "principal moment of inertia": ("kg m^2", Bound(1e-12, 1e8, "positive (a body has extent in every direction): "
                                                                "a milligram at a millimetre to a haul truck's body "
                                                                "about its vertical axis (about 1e7 kg m^2)")),
    "collision size": ("m", Bound(1e-4, 100.0, "a box side, sphere radius or cylinder radius or length: a tenth "
                                               "of a millimetre to ten times the longest vehicles (about 15 m)")),
    "origin offset": ("m", Bound(-100.0, 100.0, "a joint, centre of mass or shape within ten times the longest "
                                                "vehicles (about 15 m) of its parent frame")),
    "revolute limit": ("rad", Bound(-6.3, 6.3, "at most a turn either way (a joint that turns further is "
                                               "continuous)")),
    "prismatic limit": ("m", Bound(-10.0, 10.0, "suspension travel is below 1 m on any vehicle (haul trucks "
                                                "about 0.3 m); ten times that")),
}


def _urdf_value(where: str, quantity: str, value: float) -> None:
    unit, bound = URDF_BOUNDS[quantity]
    if not (math.isfinite(value) and bound.holds(float(value))):
        raise InputError(f"{where}: {quantity} {value:g} {unit} is outside the physical range {bound.text()} {unit} "
                         f"({bound.source}); check the value and its unit")


def _finite(where: str, what: str, values) -> None:
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"{where}: {what} {' '.join(f'{v:g}' for v in values)} is not finite")


def _written_sizes(kind: str, size) -> list[float]:
    """The sizes a URDF writes for a shape read_urdf keeps as (half) extents, m: a box's sides, a
    sphere's radius, a cylinder's radius and length."""
    if kind == "box":
        return [2.0 * v for v in size]
    if kind == "cylinder":
        return [size[0], 2.0 * size[1]]
    return list(size)


def check_urdf(path: Any, links: Mapping[str, Any], joints: Any) -> None:
    """Refuse (InputError, one line naming the file and the link or joint) a URDF outside
    physical bounds (:data:`URDF_BOUNDS`): ``links`` and ``joints`` as
    offroadbench.sim.engines.base.read_urdf reads them. Every link needs an ``<inertial>``, a mass
    and a positive definite inertia tensor (kg m^2) that a real body can have (its principal moments
    meet the triangle inequality, as MuJoCo demands) within range; collision shapes and origins are
    sized within range; a joint names links of the file, turns about a non-zero finite axis, and its
    limits (rad or m) are ordered and within range; the links form one tree."""
    import numpy as np

    for name, link in links.items():
        where = f"URDF {path}: link {name!r}"
        if not link.has_inertial:
            raise InputError(f"{where} has no <inertial> (mass and inertia): every link of a vehicle needs one "
                             "(PyBullet would give it 1 kg, MuJoCo none)")
        _urdf_value(where, "mass", link.mass)
        _finite(where, "centre of mass", link.com)
        for v in link.com:
            _urdf_value(f"{where} centre of mass", "origin offset", v)
        (ixx, iyy, izz), (ixy, ixz, iyz) = link.inertia, link.products
        _finite(where, "inertia (ixx iyy izz ixy ixz iyz)", (ixx, iyy, izz, ixy, ixz, iyz))
        moments = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float))
        if moments[0] <= 0.0:
            raise InputError(f"{where}: its inertia tensor (ixx {ixx:g}, iyy {iyy:g}, izz {izz:g}, ixy {ixy:g}, "
                             f"ixz {ixz:g}, iyz {iyz:g} kg m^2) is not positive definite (smallest principal moment "
                             f"{moments[0]:g}); a real body's is")
        for m in moments:
            _urdf_value(where, "principal moment of inertia", float(m))
        if moments[0] + moments[1] < moments[2] * (1.0 - 1e-6):
            raise InputError(f"{where}: its principal moments of inertia {moments[0]:g}, {moments[1]:g}, "
                             f"{moments[2]:g} kg m^2 break the triangle inequality (the two smaller must sum to at "
                             "least the largest): no real body has them")
        for kind, size, pos, euler in link.shapes:
            for v in _written_sizes(kind, size):
                _urdf_value(f"{where} {kind}", "collision size", v)
            _finite(f"{where} {kind}", "origin rpy", euler)
            for v in pos:
                _urdf_value(f"{where} {kind}", "origin offset", v)
    children: set[str] = set()
    for j in joints:
        where = f"URDF {path}: joint {j.name!r}"
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise InputError(f"{where}: its {role} link {link!r} is not a link of the file")
        if j.child in children:
            raise InputError(f"{where}: link {j.child!r} is the child of two joints; the links must form a tree")
        children.add(j.child)
        _finite(where, "origin rpy", j.euler)
        for v in j.pos:
            _urdf_value(f"{where} origin", "origin offset", v)
        _finite(where, "axis", j.axis)
        if j.kind != "fixed" and not any(j.axis):
            raise InputError(f"{where}: its axis is the zero vector; a joint turns or slides along a direction")
        if j.limits is not None and j.kind in ("revolute", "prismatic"):
            lo, hi = j.limits
            for v in (lo, hi):
                _urdf_value(f"{where} limit", f"{j.kind} limit", v)
            if lo > hi:
                raise InputError(f"{where}: limit lower {lo:g} is above upper {hi:g}")
        for what, v in (("effort", j.effort), ("velocity", j.velocity)):
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise InputError(f"{where}: limit {what} {v:g} must be a finite number >= 0")
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise InputError(f"URDF {path}: the links must form one tree with one root; roots: {', '.join(roots) or 'none'}")


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
    lines += ["### The vehicle's URDF", "",
              ("Every link of the model file a `vehicle.toml` names needs an `<inertial>`; its inertia tensor must "
               "be positive definite and meet the triangle inequality; a joint's limits must be ordered "
               "(offroadbench.bounds.check_urdf, when the vehicle is loaded)."), "",
              "| quantity | unit | physical range | source |", "|---|---|---|---|"]
    lines += [f"| {name} | {unit} | {b.text()} | {b.source} |" for name, (unit, b) in URDF_BOUNDS.items()]
    lines.append("")
    return lines
