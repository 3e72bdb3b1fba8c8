"""Vehicle descriptions: a URDF plus a TOML table of limits, chosen by name or by path.

``load_vehicle("husky")`` reads the ``husky/vehicle.toml`` found through
:mod:`offroadbench.resources` (the shipped vehicles, and ``vehicles/`` folders on the
``OFFROADBENCH_PATH`` search path); any other ``vehicle.toml`` path works too, so new vehicles are
added as files. The TOML's ``[vehicle]`` table maps one-to-one onto :class:`VehicleSpec`.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from offroadbench import resources
from offroadbench.config import check_choice, check_range, from_dict, load_toml
from offroadbench.errors import InputError
from offroadbench.bounds import check_bounds
from offroadbench.registry import Registry, unknown_name

__all__ = ["STEERING_KINDS", "VehicleSpec", "VEHICLES", "check_model_file", "load_vehicle", "list_vehicles", "vehicle_files", "vehicle_from_table"]

#: the steering kinds a vehicle.toml may name (VehicleSpec.steering)
STEERING_KINDS = ("skid", "ackermann", "rocker_bogie")


@dataclass(frozen=True, kw_only=True)
class VehicleSpec:
    """A ground vehicle: its URDF, geometry the drive needs, limits and contact friction.

    ``steering`` picks how (v, omega) commands become joint commands and which path tracker drives it
    (offroadbench.sim.trial.steering): ``skid`` (both sides at their own speed: wheeled skid-steer,
    and tracks as rows of road wheels), ``ackermann`` (steered front wheels, bicycle-model pure
    pursuit: offroadbench.sim.trial.ackermann) or ``rocker_bogie`` (six wheels, corner-wheel
    steering, rockers tied by a differential).
    """

    name: str
    """Short name, e.g. ``husky``."""
    urdf: str
    """Path of the URDF; relative paths are resolved against the TOML's folder by load_vehicle."""
    left_wheel_joints: tuple[str, ...]
    """Names of the left-side wheel joints (axis +y, positive spin drives forward)."""
    right_wheel_joints: tuple[str, ...]
    """Names of the right-side wheel joints."""
    wheel_radius_m: float
    """Rolling radius of the wheels, metres."""
    wheel_width_m: float | None = None
    """Width of the tyre's tread, metres (the ``terramechanics`` tyre model's b; None: that model
    cannot be used)."""
    track_contact_length_m: float | None = None
    """A tracked vehicle's belt ground contact length, m: with it, on the ``terramechanics`` tyre model
    each side's road wheels are the segments of one belt of this length and ``wheel_width_m`` under the
    Bekker / Wong track relations (offroadbench.sim.tyre_laws.track_patch); None: wheels (a track as a
    row of wheels). Rigid-ground tyre models ignore it."""
    track_m: float
    """Lateral distance between left and right wheel centres, metres."""
    max_speed_m_s: float
    """Top forward speed, m/s."""
    max_accel_m_s2: float
    """Longitudinal acceleration limit used by the speed profile, m/s^2."""
    max_jerk_m_s3: float
    """Longitudinal jerk limit used by the speed profile, m/s^3."""
    max_yaw_rate_rad_s: float
    """Largest commanded yaw rate, rad/s."""
    skid_track_factor: float = 1.0
    """Effective skid-steer track divided by the geometric track (> 1: wheels slip when turning)."""
    wheel_torque_limit_nm: float
    """Largest torque each wheel motor applies, N m."""
    wheel_friction: float
    """Lateral (Coulomb) friction coefficient of the tyres; Bullet multiplies it by the terrain's."""
    chassis_friction: float = 0.5
    """Friction coefficient of the chassis body when it touches the ground."""
    tyre_stiffness_n_m: float | None = None
    """Vertical contact stiffness of each tyre, N/m (None: Bullet's rigid contact)."""
    tyre_damping_n_s_m: float | None = None
    """Vertical contact damping of each tyre, N s/m (needed with tyre_stiffness_n_m)."""
    wheel_spin_inertia_kg_m2: float | None = None
    """Moment of inertia of each wheel about its axle as the motor sees it, kg m^2: the tyre's own
    plus the gearbox's reflected motor inertia (rotor inertia x gear ratio^2). Set on the wheel links
    after loading (None: the URDF's value). See offroadbench.sim.engines.pybullet.tyres for why it matters."""
    driven_wheel_joints: tuple[str, ...] = ()
    """The wheel joints with a motor (empty: all of them); the others roll freely (a rear-wheel-drive car's
    front wheels)."""
    belt_drive: bool = False
    """A tracked vehicle whose tracks are rows of road wheels (``skid`` steering): each side's wheels turn
    as one belt, at one speed, so the side's motor torque (``wheel_torque_limit_nm`` x the side's wheel
    count: the sprocket's) goes through whichever of its wheels bear on the ground, not a fixed share per
    wheel (False: every wheel is its own drive)."""
    suspension_joints: tuple[str, ...] = ()
    """Prismatic joints (axis +z of the body, positive: the wheel moves up, towards the chassis) that carry
    the wheels on springs, one per sprung wheel, their travel the URDF's joint limits (empty: the wheels
    are fixed to the chassis, or to their knuckles)."""
    suspension_stiffness_n_m: float | None = None
    """Spring rate of each suspension joint, N/m (at the wheel: the wheel rate)."""
    suspension_damping_n_s_m: float | None = None
    """Damping of each suspension joint, N s/m."""
    suspension_preload_n: float | None = None
    """Spring force at joint position 0 (the URDF's ride height), N: a joint at ``q`` pushes its wheel
    down with ``preload + k q + c q_dot``. The share of the sprung weight each wheel carries on Earth puts
    the parked vehicle at the URDF's ride height there (and higher, on its droop stops, in lower gravity)."""
    steering: str = "skid"
    """How the vehicle steers: ``skid``, ``ackermann`` or ``rocker_bogie`` (see the class docstring)."""
    steer_joints: tuple[str, ...] = ()
    """Steering joints (revolute about the body's z axis, position-controlled; ``ackermann`` and
    ``rocker_bogie``), each turning the wheel of the same index in ``steered_wheel_joints``."""
    steered_wheel_joints: tuple[str, ...] = ()
    """The wheel joints the ``steer_joints`` turn, in the same order (each also in the left or right list)."""
    max_steer_angle_deg: float = 0.0
    """Largest steering angle of a steered wheel, degrees (``ackermann``, ``rocker_bogie``)."""
    max_steer_rate_deg_s: float = 0.0
    """Largest steering rate, deg/s (the steering servo's speed)."""
    steer_torque_limit_nm: float = 0.0
    """Largest torque of a steering servo, N m."""
    differential_joints: tuple[str, ...] = ()
    """``rocker_bogie``: the left and right rocker joints, tied by the differential so that their
    angles relative to the body are opposite (the body's pitch is the mean of the rockers')."""
    rated_climb_grade_deg: float | None = None
    """Steepest grade the maker says the vehicle climbs, degrees (spec sheet; shown beside the
    measured figure by offroadbench.sim.rigs.vehicle_check, never used in the simulation)."""
    rated_side_slope_deg: float | None = None
    """Steepest side slope the maker says the vehicle traverses, degrees (spec sheet; as above)."""
    rated_step_m: float | None = None
    """Highest step the maker says the vehicle climbs, metres (spec sheet; as above)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "left_wheel_joints", tuple(self.left_wheel_joints))
        object.__setattr__(self, "right_wheel_joints", tuple(self.right_wheel_joints))
        for name in ("driven_wheel_joints", "steer_joints", "steered_wheel_joints", "differential_joints",
                     "suspension_joints"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        if not self.left_wheel_joints or not self.right_wheel_joints:
            raise InputError(f"vehicle {self.name!r}: left_wheel_joints and right_wheel_joints must not be empty")
        for name in ("wheel_radius_m", "track_m", "max_speed_m_s", "max_accel_m_s2", "max_jerk_m_s3",
                     "max_yaw_rate_rad_s", "wheel_torque_limit_nm"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)
        check_range(self, "skid_track_factor", self.skid_track_factor, lo=1.0)
        check_range(self, "wheel_friction", self.wheel_friction, lo=0, lo_open=True)
        check_range(self, "chassis_friction", self.chassis_friction, lo=0)
        for name in ("rated_climb_grade_deg", "rated_side_slope_deg"):
            if getattr(self, name) is not None:
                check_range(self, name, getattr(self, name), lo=0, hi=90, lo_open=True)
        if self.wheel_width_m is not None:
            check_range(self, "wheel_width_m", self.wheel_width_m, lo=0, lo_open=True)
        if self.track_contact_length_m is not None:
            check_range(self, "track_contact_length_m", self.track_contact_length_m, lo=0, lo_open=True)
            if self.wheel_width_m is None or self.steering != "skid":
                raise InputError(f"vehicle {self.name!r}: track_contact_length_m needs wheel_width_m (the belt's "
                                 "width) and steering = 'skid'")
        if self.rated_step_m is not None:
            check_range(self, "rated_step_m", self.rated_step_m, lo=0, lo_open=True)
        if self.wheel_spin_inertia_kg_m2 is not None:
            check_range(self, "wheel_spin_inertia_kg_m2", self.wheel_spin_inertia_kg_m2, lo=0, lo_open=True)
        check_choice(self, "steering", self.steering, STEERING_KINDS)
        check_range(self, "max_steer_angle_deg", self.max_steer_angle_deg, lo=0, hi=90)
        check_range(self, "max_steer_rate_deg_s", self.max_steer_rate_deg_s, lo=0)
        check_range(self, "steer_torque_limit_nm", self.steer_torque_limit_nm, lo=0)
        self._check_steering()
        stray = [w for w in self.driven_wheel_joints if w not in self.wheel_joints]
        if stray:
            raise InputError(f"vehicle {self.name!r}: driven_wheel_joints {', '.join(stray)} are not wheel joints")
        self._check_suspension()
        if (self.tyre_stiffness_n_m is None) != (self.tyre_damping_n_s_m is None):
            raise InputError("vehicle: give both tyre_stiffness_n_m and tyre_damping_n_s_m, or neither")
        if self.tyre_stiffness_n_m is not None:
            check_range(self, "tyre_stiffness_n_m", self.tyre_stiffness_n_m, lo=0, lo_open=True)
            check_range(self, "tyre_damping_n_s_m", self.tyre_damping_n_s_m, lo=0)
        check_bounds(self, f"vehicle {self.name!r}")  # physical ranges with their sources (offroadbench.bounds)

    def _check_suspension(self) -> None:
        names = ("suspension_stiffness_n_m", "suspension_damping_n_s_m", "suspension_preload_n")
        if not self.suspension_joints:
            given = [n for n in names if getattr(self, n) is not None]
            if given:
                raise InputError(f"vehicle {self.name!r}: {', '.join(given)} given without suspension_joints")
            return
        missing = [n for n in names if getattr(self, n) is None]
        if missing:
            raise InputError(f"vehicle {self.name!r}: suspension_joints need {', '.join(missing)}")
        check_range(self, "suspension_stiffness_n_m", self.suspension_stiffness_n_m, lo=0, lo_open=True)
        check_range(self, "suspension_damping_n_s_m", self.suspension_damping_n_s_m, lo=0)
        check_range(self, "suspension_preload_n", self.suspension_preload_n, lo=0)
        clash = [n for n in self.suspension_joints if n in self.wheel_joints + self.steer_joints]
        if clash:
            raise InputError(f"vehicle {self.name!r}: suspension_joints {', '.join(clash)} are wheel or steering joints")

    def _check_steering(self) -> None:
        if self.belt_drive and (self.steering != "skid" or self.driven_wheel_joints):
            raise InputError(f"vehicle {self.name!r}: belt_drive = true needs steering = 'skid' and every wheel "
                             f"driven (no driven_wheel_joints), got steering = {self.steering!r}")
        if self.steering == "skid":
            if self.steer_joints or self.differential_joints:
                raise InputError(f"vehicle {self.name!r}: steering = 'skid' takes no steer_joints or differential_joints")
            return
        if not self.steer_joints or len(self.steer_joints) != len(self.steered_wheel_joints):
            raise InputError(f"vehicle {self.name!r}: steering = {self.steering!r} needs steer_joints and "
                             f"steered_wheel_joints of the same length > 0, got {len(self.steer_joints)} and "
                             f"{len(self.steered_wheel_joints)}")
        stray = [w for w in self.steered_wheel_joints if w not in self.wheel_joints]
        if stray:
            raise InputError(f"vehicle {self.name!r}: steered_wheel_joints {', '.join(stray)} are not wheel joints")
        zero = [n for n in ("max_steer_angle_deg", "max_steer_rate_deg_s", "steer_torque_limit_nm") if getattr(self, n) <= 0]
        if zero:
            raise InputError(f"vehicle {self.name!r}: steering = {self.steering!r} needs {', '.join(zero)} > 0")
        if self.steering == "rocker_bogie" and len(self.differential_joints) != 2:
            raise InputError(f"vehicle {self.name!r}: steering = 'rocker_bogie' needs differential_joints = "
                             f"[left rocker, right rocker], got {list(self.differential_joints)}")

    @property
    def wheel_joints(self) -> tuple[str, ...]:
        return self.left_wheel_joints + self.right_wheel_joints

    def is_driven(self, wheel_joint: str) -> bool:
        """Whether ``wheel_joint`` has a motor (``driven_wheel_joints``; all wheels when it is empty)."""
        return not self.driven_wheel_joints or wheel_joint in self.driven_wheel_joints


def _toml_of(name: str, obj: object) -> Path:
    """An entry point names a vehicle.toml, or the folder holding one (a path or a Traversable)."""
    if not isinstance(obj, (str, os.PathLike)) and not hasattr(obj, "joinpath"):
        raise TypeError(f"entry point {name!r} must name a vehicle.toml path, got {type(obj).__name__}")
    path = Path(str(obj))
    path = path / "vehicle.toml" if path.is_dir() else path
    if not path.is_file():
        raise ValueError(f"vehicle {name!r}: {path} does not exist")
    return path


#: vehicles of installed packages: entry-point group ``offroadbench.vehicles``, each naming a
#: vehicle.toml (or its folder)
VEHICLES: Registry[Path] = Registry("vehicle", entry_point_group="offroadbench.vehicles", adapt=_toml_of)


def vehicle_files() -> dict[str, Path]:
    """{name: vehicle.toml} of every known vehicle: the search path and the shipped ones
    (:func:`offroadbench.resources.vehicle_files`, read on every call), then installed packages'."""
    found = resources.vehicle_files()
    for name, path in VEHICLES.items():
        found.setdefault(name, path)
    return dict(sorted(found.items()))


def list_vehicles() -> list[str]:
    """Names of every known vehicle (:func:`vehicle_files`)."""
    return list(vehicle_files())


def load_vehicle(name_or_path: str | Path) -> VehicleSpec:
    """Load a vehicle by name (``husky``) or by the path of its ``vehicle.toml``.

    The URDF path is resolved against the TOML's folder and must exist, be a URDF within physical
    bounds (offroadbench.bounds.check_urdf: masses, inertias, shape sizes, joint limits) and have
    the joints the TOML names; otherwise an InputError naming the file (one line).
    """
    text = str(name_or_path)
    path = Path(text)
    if not (path.suffix == ".toml" or path.is_file()):
        found = vehicle_files()
        if text not in found:
            raise unknown_name("vehicle", text, found, extra="(or give the path of a vehicle.toml)")
        path = found[text]
    data = load_toml(path)
    if "vehicle" not in data:
        raise InputError(f"{path}: no [vehicle] table")
    spec = from_dict(VehicleSpec, data["vehicle"], where=f"{path} [vehicle]")
    urdf = Path(spec.urdf)
    if not urdf.is_absolute():
        urdf = path.parent / urdf
    if not urdf.is_file():
        raise InputError(f"{path}: urdf {spec.urdf!r} not found at {urdf}")
    urdf = urdf.resolve()
    check_model_file(spec, urdf)
    return dataclasses.replace(spec, urdf=str(urdf))


def check_model_file(spec: VehicleSpec, urdf: str | Path) -> None:
    """Refuse (InputError, one line naming the file) a model file that is not a URDF, is outside
    physical bounds (offroadbench.bounds.check_urdf), or lacks a joint ``spec`` names."""
    from offroadbench.bounds import check_urdf
    from offroadbench.sim.engines.base import read_urdf

    links, joints = read_urdf(str(urdf))
    check_urdf(urdf, links, joints)
    names = {j.name for j in joints}
    named = (spec.wheel_joints + spec.steer_joints + spec.differential_joints + spec.suspension_joints)
    missing = [n for n in dict.fromkeys(named) if n not in names]
    if missing:
        raise InputError(f"vehicle {spec.name!r}: URDF {urdf} has no joint(s) {', '.join(missing)}")


def vehicle_from_table(table: Mapping[str, Any], where: str = "[vehicle]"):
    """The vehicle of a ``[vehicle]`` table: ``name`` (a known vehicle or a vehicle.toml path,
    default husky) and any VehicleSpec fields to change."""
    table = dict(table)
    spec = load_vehicle(table.pop("name", "husky"))
    known = {f.name for f in dataclasses.fields(VehicleSpec)} - {"name", "urdf"}
    unknown = sorted(set(table) - known)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: name, {', '.join(sorted(known))}")
    return dataclasses.replace(spec, **table) if table else spec
