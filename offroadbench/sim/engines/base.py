"""What every engine shares, written once above the engine packages (engines/pybullet, engines/mujoco).

Nothing here imports a physics engine: the vehicle's URDF as data (links' masses, inertias and
collision shapes, joints; :func:`read_urdf`, :func:`urdf_mass_kg`) and where a vehicle is spawned
clear of the terrain (:func:`max_height_near`), each written once for every engine.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import TYPE_CHECKING

from offroadbench.errors import InputError

if TYPE_CHECKING:
    from offroadbench.heightmap import Heightmap

__all__ = ["UrdfJoint", "UrdfLink", "max_height_near", "read_urdf", "settle", "spawn_height_m", "suspension_rest_m",
           "unsprung_kg", "urdf_mass_kg"]


def max_height_near(hm: Heightmap, x_m: float, y_m: float, radius_m: float) -> float:
    """Highest terrain sample in the square of half-side ``radius_m`` around (x, y), clipped to the
    map, metres (where every engine spawns a vehicle clear of the ground); ``z_max`` off the map."""
    c0 = max(0, int(math.floor((x_m - radius_m) / hm.cell_size_m)))
    c1 = min(hm.cols - 1, int(math.ceil((x_m + radius_m) / hm.cell_size_m)))
    r0 = max(0, int(math.floor((y_m - radius_m) / hm.cell_size_m)))
    r1 = min(hm.rows - 1, int(math.ceil((y_m + radius_m) / hm.cell_size_m)))
    if c0 > c1 or r0 > r1:
        return hm.z_max_m
    return float(hm.z[r0 : r1 + 1, c0 : c1 + 1].max())


def spawn_height_m(hm: Heightmap, x_m: float, y_m: float, chassis_reach_m: float, wheel_radius_m: float,
                   bottom_m: float, clearance_m: float) -> float:
    """Height of the vehicle's base at spawn, m: its lowest point ``bottom_m`` below the base and
    ``clearance_m`` above the highest terrain sample within the chassis' reach (half its diagonal)
    plus a wheel radius of (x, y)."""
    ground = max_height_near(hm, x_m, y_m, chassis_reach_m + wheel_radius_m)
    return ground + bottom_m + clearance_m


def settle(world) -> None:
    """The end of every engine's spawn: the wheels braked (commanded to 0 rad/s) while the vehicle
    settles for ``sim.settle_time_s`` (the clock starts after it)."""
    world.command_wheels(0.0, 0.0)
    for _ in range(int(round(world.sim.settle_time_s * world.sim.physics_rate_hz))):
        world.step()


@dataclass(frozen=True)
class UrdfLink:
    """A URDF link: mass kg, centre of mass m, diagonal inertia kg m^2, collision shapes
    (type, size tuple, position, euler angles)."""

    name: str
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float]
    shapes: tuple  # (type, size tuple, pos, euler)
    products: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The products of inertia (ixy, ixz, iyz), kg m^2 (the engines use the diagonal; the bounds
    check the whole tensor: offroadbench.bounds.check_urdf)."""
    has_inertial: bool = True
    """Whether the link has an ``<inertial>`` (without one: mass and inertia 0 here)."""


@dataclass(frozen=True)
class UrdfJoint:
    """A URDF joint: kind (``continuous``, ``revolute``, ``fixed``, ...), parent and child link, origin, axis."""

    name: str
    kind: str
    parent: str
    child: str
    pos: tuple[float, float, float]
    euler: tuple[float, float, float]
    axis: tuple[float, float, float]
    limits: tuple[float, float] | None = None
    """(lower, upper) of the joint's ``<limit>`` (rad or m), None without one."""
    effort: float | None = None
    """The ``<limit>``'s effort (N or N m), None without one (no engine uses it)."""
    velocity: float | None = None
    """The ``<limit>``'s velocity (rad/s or m/s), None without one (no engine uses it)."""


def _floats(text: str | None, n: int, default: float = 0.0) -> tuple[float, ...]:
    if text is None:
        return (default,) * n
    vals = tuple(float(v) for v in text.split())
    if len(vals) != n:
        raise ValueError(f"expected {n} numbers, got {text!r}")
    return vals


def _opt_float(text: str | None) -> float | None:
    return None if text is None else float(text)


def read_urdf(path: str) -> tuple[dict[str, UrdfLink], list[UrdfJoint]]:
    """The links (mass, centre of mass, diagonal inertia, collision shapes) and joints of a URDF.

    A file that is not XML, or whose root is not ``<robot>`` with at least one ``<link>``, is an
    InputError naming it (one line)."""
    try:
        root = ET.parse(path).getroot()
        if root.tag != "robot":
            raise ValueError(f"its root element is <{root.tag}>, a URDF's is <robot>")
        if root.find("link") is None:
            raise ValueError("it has no <link>")
        links = {}
        for el in root.findall("link"):
            inertial = el.find("inertial")
            mass, com, inertia = 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
            products = (0.0, 0.0, 0.0)
            if inertial is not None:
                origin = inertial.find("origin")
                if origin is not None and any(_floats(origin.get("rpy"), 3)):
                    raise ValueError(f"link {el.get('name')}: a rotated inertial frame is not supported")
                com = _floats(origin.get("xyz") if origin is not None else None, 3)
                mass = float(inertial.find("mass").get("value"))
                i = inertial.find("inertia")
                inertia = (float(i.get("ixx")), float(i.get("iyy")), float(i.get("izz")))
                products = tuple(float(i.get(k, "0")) for k in ("ixy", "ixz", "iyz"))
            shapes = []
            for col in el.findall("collision"):
                origin = col.find("origin")
                pos = _floats(origin.get("xyz") if origin is not None else None, 3)
                euler = _floats(origin.get("rpy") if origin is not None else None, 3)
                geo = col.find("geometry")[0]
                if geo.tag == "box":
                    shapes.append(("box", tuple(0.5 * v for v in _floats(geo.get("size"), 3)), pos, euler))
                elif geo.tag == "sphere":
                    shapes.append(("sphere", (float(geo.get("radius")),), pos, euler))
                elif geo.tag == "cylinder":
                    shapes.append(("cylinder", (float(geo.get("radius")), 0.5 * float(geo.get("length"))), pos, euler))
                else:
                    raise ValueError(f"link {el.get('name')}: collision geometry {geo.tag!r} is not supported")
            links[el.get("name")] = UrdfLink(el.get("name"), mass, com, inertia, tuple(shapes), products,
                                             inertial is not None)
        joints = []
        for el in root.findall("joint"):
            origin = el.find("origin")
            axis = el.find("axis")
            limit = el.find("limit")
            bounds = effort = velocity = None
            if limit is not None and limit.get("lower") is not None and limit.get("upper") is not None:
                bounds = (float(limit.get("lower")), float(limit.get("upper")))
            if limit is not None:
                effort, velocity = _opt_float(limit.get("effort")), _opt_float(limit.get("velocity"))
            joints.append(UrdfJoint(el.get("name"), el.get("type"), el.find("parent").get("link"),
                                 el.find("child").get("link"),
                                 _floats(origin.get("xyz") if origin is not None else None, 3),
                                 _floats(origin.get("rpy") if origin is not None else None, 3),
                                 _floats(axis.get("xyz") if axis is not None else None, 3) if axis is not None
                                 else (1.0, 0.0, 0.0), bounds, effort, velocity))
    except (ET.ParseError, AttributeError, TypeError, ValueError, IndexError, OSError) as exc:
        raise InputError(f"URDF {path}: not a URDF that can be read ({exc})") from None
    return links, joints


def urdf_mass_kg(path: str) -> float:
    """Total mass of a URDF's links, kg (summed in the file's order)."""
    links, _ = read_urdf(path)
    return sum(link.mass for link in links.values())


def unsprung_kg(path: str, suspension_joints) -> float:
    """Mean mass below one of the URDF's ``suspension_joints`` (its strut, wheel and what they carry), kg."""
    links, joints = read_urdf(path)
    below: dict[str, list[str]] = {}
    for j in joints:
        below.setdefault(j.parent, []).append(j.child)

    def subtree(link: str) -> float:
        return links[link].mass + sum(subtree(c) for c in below.get(link, []))

    struts = [j for j in joints if j.name in suspension_joints]
    return sum(subtree(j.child) for j in struts) / len(struts)


def suspension_rest_m(spec, gravity_m_s2: float) -> float:
    """Where a sprung vehicle's struts (VehicleSpec.suspension_*) rest, m: each carrying an equal share
    of the sprung weight, ``q = (m_s g / n - preload) / k``, held within the URDF's travel. Both engines
    spawn the struts there, so a vehicle is put down at rest in any gravity (the preload is the Earth
    ride height's: in lunar gravity the struts rest on their droop stops, and a vehicle spawned at the
    Earth ride height was thrown up by its springs). 0 for a vehicle without suspension."""
    if not spec.suspension_joints:
        return 0.0
    links, joints = read_urdf(spec.urdf)
    n = len(spec.suspension_joints)
    sprung = sum(link.mass for link in links.values()) - n * unsprung_kg(spec.urdf, spec.suspension_joints)
    q = (sprung * gravity_m_s2 / n - spec.suspension_preload_n) / spec.suspension_stiffness_n_m
    struts = [j for j in joints if j.name in spec.suspension_joints and j.limits is not None]
    lo = max((j.limits[0] for j in struts), default=-math.inf)
    hi = min((j.limits[1] for j in struts), default=math.inf)
    return min(hi, max(lo, q))
