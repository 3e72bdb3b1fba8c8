"""The MuJoCo engine's settings table, ``[sim.mujoco]`` (SimConfig.mujoco): plain data, no MuJoCo
import, so a study's settings validate without the engine installed."""

from __future__ import annotations

from dataclasses import dataclass

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError

__all__ = ["ContactTuning", "MUJOCO_CONTACT", "MuJoCoConfig"]


@dataclass(frozen=True, kw_only=True)
class MuJoCoConfig:
    """The MuJoCo engine's own settings (a study's ``[sim.mujoco]`` table): contact and stepping
    settings that are not in the vehicle's spec, tuned to PyBullet's ride. The other engines ignore
    them."""

    wheel_solref: tuple[float, float] | None = None
    """solref of the wheel-terrain contact, (time constant s, damping ratio); None: from the
    spec's tyre stiffness and damping (offroadbench.sim.engines.mujoco.world's module docstring)."""
    wheel_margin_m: float = 0.0
    """Geom margin of the wheels: contacts are found within this distance, m."""
    wheel_gap_m: float = 0.0
    """Geom gap of the wheels: a found contact acts once closer than ``margin - gap``, m."""
    refsafe: bool = True
    """MuJoCo's ``refsafe``: time constants below two steps are raised to two steps."""
    chassis_solref: tuple[float, float] = (0.02, 1.0)
    """The chassis-terrain contact's solref (time constant s, damping ratio): MuJoCo's default."""
    solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    """solimp of the wheels' contacts (MuJoCo's default)."""
    chassis_solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    """solimp of the chassis' contacts (MuJoCo's default)."""
    chassis_condim: int = 3
    """Contact dimensionality of the chassis: 3 sliding friction (as Bullet), 4 adds torsional, 6 rolling."""
    cone: str = "pyramidal"
    """MuJoCo's friction cone for the contacts it owns (the chassis'): ``pyramidal`` or ``elliptic``."""
    min_rate_hz: int = 120
    """MuJoCo steps at least this often: a trial's step (``SimConfig.physics_rate_hz``) is split into
    ``ceil(min_rate_hz / physics_rate_hz)`` MuJoCo steps, the tyre forces applied at each. Below
    120 Hz the ride is bumpier than PyBullet's at 60 Hz (benchmarks/RESULTS.md, 'MuJoCo')."""
    ccd_iterations: int = 10
    """MuJoCo's convex-collision iterations (its default 35): 10 gave the same trials to the last
    printed digit and 1.2x the speed on paper terrain (the chassis box against the hfield's prisms)."""
    tyres_each_substep: bool = True
    """True: the tyre forces are computed (and the contacts read) at every MuJoCo step. False:
    once per trial step, from the contacts of its last MuJoCo step, and held over its MuJoCo
    steps (as PyBullet applies them once per 60 Hz step): on the paper missions 1.2x the speed
    with a ride as close to PyBullet's (RMS vertical acceleration -2.1 % against -4.6 %), but the
    Jackal then fails 4 rows of ``vehicle check`` (a 2 rad/s turn at 1 m/s overshoots by 13 %,
    it climbs a 0.118 m step against its 0.098 m bound), so it is not the default."""
    servo_gain: float = 4.0
    """Wheel servo gain ``kv`` in units of (spin inertia / dt): the velocity error shrinks by
    1 / (1 + gain) per step before the torque limit."""
    tyre_loop: str = "auto"
    """Where the tyre loop runs (the ``coulomb`` tyres and the ``terramechanics`` soil): ``compiled``
    (numba: offroadbench.sim.engines.mujoco._tyres_c and ``_soil_c``, the same forces to the last
    bit at a fraction of the cost), ``python`` (the interpreted loop over CoulombBristles or
    SoilWheels) or ``auto`` (compiled when numba is installed, else python). Vehicles with
    articulated wheels (steering, rockers, bogies) always use the Python loop."""
    hfield_collision: str = "closed_form"
    """How the wheels and the chassis collide with the terrain's height field
    (offroadbench.sim.engines.mujoco._hfield_c): ``mujoco`` (MuJoCo's own ``mjc_ConvexHField``, a
    GJK/EPA call per candidate prism); ``exact`` (the chassis box's early-out when no height sample
    under it reaches its lowest point, else MuJoCo's own call: the same contacts to the bit, so the
    same trials as ``mujoco``); ``closed_form`` (``exact`` plus the sphere wheels' prisms in closed
    form: MuJoCo's contacts to ~1e-15 m and normals to ~1e-10 at driving depths, so trials within
    run-to-run chaos, not to the bit: 1.5-1.7x the trials' speed on 36 paired paper missions with
    no outcome flipped, benchmarks/RESULTS.md 'Issue 41'). ``exact`` and ``closed_form`` need numba; without it
    the world uses ``mujoco`` (logged), which gives ``exact``'s trials, not ``closed_form``'s.
    Studies run before this setting existed (MuJoCo's own collision) are reproduced by ``exact``."""

    def __post_init__(self) -> None:
        for name in ("wheel_solref", "chassis_solref", "solimp", "chassis_solimp"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, tuple(float(v) for v in value))
        if self.wheel_solref is not None:
            _check_pair(self, "wheel_solref", self.wheel_solref)
        _check_pair(self, "chassis_solref", self.chassis_solref)
        for name in ("solimp", "chassis_solimp"):
            value = getattr(self, name)
            if len(value) != 3 or not (0.0 < value[0] < 1.0 and 0.0 < value[1] < 1.0 and value[2] > 0.0):
                raise InputError(f"MuJoCoConfig.{name} = {list(value)}: expected [d0, dwidth, width] with "
                                 "0 < d0, dwidth < 1 and width > 0 (MuJoCo's solimp)")
        check_range(self, "wheel_margin_m", self.wheel_margin_m, lo=0)
        check_range(self, "wheel_gap_m", self.wheel_gap_m, lo=0, hi=self.wheel_margin_m)
        check_choice(self, "chassis_condim", self.chassis_condim, (1, 3, 4, 6))
        check_choice(self, "cone", self.cone, ("pyramidal", "elliptic"))
        check_int(self, "min_rate_hz", self.min_rate_hz, lo=1, hi=100_000)
        check_int(self, "ccd_iterations", self.ccd_iterations, lo=1, hi=1000)
        check_range(self, "servo_gain", self.servo_gain, lo=0, lo_open=True)
        check_choice(self, "tyre_loop", self.tyre_loop, TYRE_LOOPS)
        check_choice(self, "hfield_collision", self.hfield_collision, HFIELD_COLLISIONS)
        for name in ("refsafe", "tyres_each_substep"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"MuJoCoConfig.{name} = {getattr(self, name)!r}: allowed true or false")


#: values of MuJoCoConfig.tyre_loop
TYRE_LOOPS = ("auto", "compiled", "python")
#: values of MuJoCoConfig.hfield_collision (offroadbench.sim.engines.mujoco._hfield_c.MODES)
HFIELD_COLLISIONS = ("mujoco", "exact", "closed_form")


def _check_pair(owner, name: str, value) -> None:
    if len(value) != 2 or not value[0] > 0.0 or not value[1] > 0.0:
        raise InputError(f"MuJoCoConfig.{name} = {list(value)}: expected [time constant s, damping ratio], both > 0")


#: the name the settings had before they became a study's table (benchmarks, RESULTS.md)
ContactTuning = MuJoCoConfig
#: the settings the MuJoCo world uses by default
MUJOCO_CONTACT = MuJoCoConfig()
