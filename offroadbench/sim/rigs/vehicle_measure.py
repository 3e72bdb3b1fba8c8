"""The row type and the measuring helpers of the vehicle check (offroadbench.sim.rigs.vehicle_check):
tilting gravity, reading yaw, loads and the centre of mass, ramping a tilt, bisecting a limit,
and whether the vehicle climbs a grade."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from offroadbench.sim.engine import TrialWorld
from offroadbench.sim.trial.steering import drive_twist


FLAT_CELL_M = 0.1


STEP_CELL_M = 0.02


@dataclass(frozen=True)
class CheckResult:
    """One figure of the vehicle check."""

    name: str
    """What was measured, e.g. ``yaw rate in place, heading 22.5 deg, command 1 rad/s``."""
    measured: float
    """The simulated figure, in ``unit``."""
    expected: float
    """What the model's own physics predicts (its grip, geometry and motor torque), in ``unit``."""
    unit: str
    """Unit of ``measured`` and ``expected``."""
    ok: bool
    """True when ``measured`` is within ``tolerance`` of ``expected``."""
    tolerance: str = ""
    """The pass rule, in words."""
    note: str = ""
    """Where the expectation comes from, and why the spec sheet's figure differs from it."""
    sheet: float | None = None
    """The spec sheet's figure for the same quantity, in ``unit`` (information only: the sheet
    assumes its own surface and test, so the row is judged against ``expected``, which comes from
    the model's own grip, geometry and motor torque)."""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


# ---------------------------------------------------------------------------- helpers
def set_tilted_gravity(world: TrialWorld, tilt_rad: float, about: str) -> None:
    """Gravity turned by ``tilt_rad`` about the world x (``about="x"``, downhill toward -y) or y
    axis (downhill toward -x): a flat world becomes a uniform slope of that angle."""
    g = world.sim.gravity_m_s2
    s, c = g * math.sin(tilt_rad), g * math.cos(tilt_rad)
    vec = (0.0, -s, -c) if about == "x" else (-s, 0.0, -c)
    world.set_gravity(*vec)


def _yaw(world: TrialWorld) -> float:
    _, q, _, _ = world.base_state()
    r = world.rotation_matrix(q)
    return math.atan2(r[3], r[0])


def run_for(world: TrialWorld, seconds: float, each: Callable[[], None] | None = None) -> None:
    for _ in range(int(round(seconds * world.sim.physics_rate_hz))):
        world.step()
        if each is not None:
            each()


def mean_yaw_rate(world: TrialWorld, v: float, omega: float, heading: float, seconds: float = 3.0,
                   at: tuple[float, float] | None = None) -> float:
    """Yaw rate (rad/s) averaged over the second half of ``seconds`` of a constant (v, omega),
    started at rest at ``at`` (default: the middle of the map)."""
    c = world.hm.width_m / 2.0
    world.spawn(*(at or (c, c)), heading)
    drive_twist(world, v, omega)
    run_for(world, seconds / 2.0)
    yaws = []
    run_for(world, seconds / 2.0, lambda: yaws.append(_yaw(world)))
    y = np.unwrap(yaws)
    return float((y[-1] - y[0]) / ((len(y) - 1) / world.sim.physics_rate_hz))


def com_height(world: TrialWorld) -> float:
    """Height of the whole vehicle's centre of mass above the ground (flat map, z = 0), metres."""
    return world.centre_of_mass_m()[2] - world.hm.z_max_m


def left_load(world: TrialWorld) -> float:
    """Summed normal force on the left wheels in the last step, N."""
    return sum(world.wheel_loads_n()[: len(world.spec.left_wheel_joints)])


def ramp_tilt(world: TrialWorld, rate_deg_s: float, stop: Callable[[], bool], start_deg: float = 0.0,
               end_deg: float = 80.0) -> float:
    """Tilt gravity about x from ``start_deg`` at ``rate_deg_s`` until ``stop()``; the angle, deg."""
    n = int(round((end_deg - start_deg) / rate_deg_s * world.sim.physics_rate_hz))
    for k in range(n):
        angle = start_deg + rate_deg_s * k / world.sim.physics_rate_hz
        set_tilted_gravity(world, math.radians(angle), "x")
        world.step()
        if stop():
            return angle
    return end_deg


def bisect_threshold(ok: Callable[[float], bool], lo: float, hi: float, tol: float) -> float:
    """Largest value in [lo, hi] for which ``ok`` holds (``ok(lo)`` assumed), to ``tol``."""
    if ok(hi):
        return hi
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo


def ratio_row(name, measured, expected, unit, lo, hi, note="") -> CheckResult:
    ok = expected > 0 and lo <= measured / expected <= hi
    return CheckResult(name, measured, expected, unit, bool(ok), f"{lo:g}-{hi:g} x expected", note)


def abs_row(name, measured, expected, unit, tol, note="") -> CheckResult:
    return CheckResult(name, measured, expected, unit, bool(abs(measured - expected) <= tol), f"within {tol:g} {unit}", note)


def climbs_grade(world: TrialWorld, grade_deg: float) -> bool:
    """True if the vehicle, at rest on a uniform grade, gains 1 m uphill within 10 s when its wheel
    speed is ramped gently (0.5 m/s^2 at the tyre, to 0.5 m/s), as a driver would start on a hill."""
    spec = world.spec
    c = world.hm.width_m / 2.0
    world.spawn(c - 3.0, c, 0.0)
    set_tilted_gravity(world, math.radians(grade_deg), "y")
    x0 = world.base_state()[0][0]
    rate = world.sim.physics_rate_hz
    climbed = False
    for k in range(int(round(10.0 * rate))):
        v = min(0.5, 0.5 * k / rate, spec.max_speed_m_s)
        drive_twist(world, v, 0.0)
        world.step()
        if world.base_state()[0][0] - x0 >= 1.0:
            climbed = True
            break
    set_tilted_gravity(world, 0.0, "y")
    return climbed
