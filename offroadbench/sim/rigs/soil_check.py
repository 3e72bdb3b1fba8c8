"""Single-wheel test rig: one wheel on a soil, driven at controlled slip and load in a physics engine.

The rig is the soil-bin test of terramechanics laboratories (Wong & Reece 1967; Ishigami et al. 2007,
Sec. 4): a carriage moves along x at a set speed, a free vertical slide carries the load, and the
wheel below it spins at a set angular velocity, so the slip is ``s = 1 - v / (r omega)``. Here the
carriage and slide are prismatic joints and the wheel a revolute joint, built by the engine (each
engine declares its rig, offroadbench.sim.engine.EngineCapabilities.soil_rig: PyBullet's
offroadbench.sim.engines.pybullet.soil_rig, MuJoCo's offroadbench.sim.engines.mujoco.soil_rig); the
soil acts on the wheel through the ``terramechanics`` tyre model's force law, the same code on every
engine (:class:`offroadbench.sim.tyre_laws.soil_wheels.SoilWheels`), on a flat heightmap. Once
steady, the rig reads:

* sinkage: the soil sinkage the tyre model reports (the series spring's part excluded);
* drawbar pull: the force the carriage's motor holds back (the soil's forward push on the wheel);
* driving torque: the torque the wheel's motor applies (the soil's resistance torque).

:func:`model_curve` gives the same quantities from the Wong-Reece integrals directly (the sinkage at
which ``F_z`` carries the load, then ``F_x`` and ``T`` there), without the engine, the tables or
the relaxation, so the rig tests the whole per-step path.

Where the model ends. The tables stop at a soil sinkage of ``MAX_SINKAGE_FRACTION`` of the radius
(0.75 r); a wheel whose load the soil cannot carry there bottoms out, and beyond it only the tyre's
series spring holds it up. Such a row is outside the model (``SoilCheck.outside_model``): the rig
and the integrals may still agree there (both hold the wheel at the cap), but that agreement says
nothing about the soil, so ``soil check`` marks those rows and leaves them out of its agreement figure.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.tyre_laws.soil_wheels import SoilWheels
from offroadbench.sim.tyre_laws.terramechanics import SoilParams, build_tables, capacity_n, static_sinkage, wheel_forces

__all__ = ["SLIPS", "SoilCheck", "model_curve", "rig_curve", "wheel_load_n"]

#: slips of the check
SLIPS = tuple(round(0.1 * i, 1) for i in range(10))


@dataclass(frozen=True)
class SoilCheck:
    """Sinkage, drawbar pull and torque against slip for one wheel, load and soil."""

    soil: str
    radius_m: float
    width_m: float
    load_n: float
    slip: np.ndarray
    sinkage_m: np.ndarray
    drawbar_pull_n: np.ndarray
    torque_nm: np.ndarray
    outside_model: np.ndarray | None = None
    """Per slip, True where the wheel bottoms out (outside the model): for the integrals, the soil at
    the tables' sinkage cap carries less than the load (:func:`~offroadbench.sim.tyre_laws.terramechanics.
    capacity_n`); for the rig, the wheel's penetration passed the tables' top at the end of the run."""
    capacity_n: np.ndarray | None = None
    """Per slip, the most the soil carries at the sinkage cap, N (the integrals only)."""


def model_curve(soil: SoilParams, radius_m: float, width_m: float, load_n: float,
                slips: Sequence[float] = SLIPS) -> SoilCheck:
    """The Wong-Reece integrals at the sinkage that carries ``load_n`` at each slip."""
    out = []
    for s in slips:
        h = static_sinkage(soil, radius_m, width_m, load_n, s)
        _, fx, t = wheel_forces(soil, radius_m, width_m, h, s)
        out.append((h, float(fx), float(t), capacity_n(soil, radius_m, width_m, s)))
    h, fx, t, cap = (np.array(c) for c in zip(*out, strict=True))
    return SoilCheck(soil.name, radius_m, width_m, load_n, np.asarray(slips, dtype=float), h, fx, t,
                     outside_model=cap < load_n, capacity_n=cap)


def wheel_load_n(spec, gravity_m_s2: float) -> float:
    """One wheel's share of the vehicle's weight, N (the URDF's masses, equal shares)."""
    from offroadbench.sim.engines.base import urdf_mass_kg

    return urdf_mass_kg(spec.urdf) * gravity_m_s2 / len(spec.wheel_joints)


def rig_curve(soil: SoilParams, radius_m: float, width_m: float, load_n: float, *, gravity_m_s2: float = 9.81,
              slips: Sequence[float] = SLIPS, wheel_speed_m_s: float = 0.6, physics_rate_hz: int = 60,
              seconds: float = 4.0, engine: str = "pybullet", progress: ProgressFn | None = None) -> SoilCheck:
    """Drive the rig on ``engine`` at each slip for ``seconds`` and average the last quarter
    (module docstring).

    ``wheel_speed_m_s`` is ``r omega``; the carriage moves at ``(1 - s)`` of it, which must stay above
    the tyre model's resistance fade speed (0.05 m/s) for the steady-state Wong-Reece forces to apply.
    The soil's force law and its constants are the same on every engine: the series spring at the
    explicit step's cap ``m / dt^2`` for the rig's load mass ``m``, the penetration damping
    ``0.5 m / dt``, the slip relaxation length the soil's K (at least 2 cm) and K_y.
    """
    from offroadbench.sim.engine import engine_capabilities

    run = engine_capabilities(engine).soil_rig()
    dt = 1.0 / physics_rate_hz
    load_kg = load_n / gravity_m_s2
    length_m = wheel_speed_m_s * seconds + 2.0
    hm = Heightmap.flat(5, math.ceil(length_m / 0.05) + 1, 0.05)
    tables = build_tables(soil, radius_m, width_m, load_kg / dt**2)
    steps = round(seconds * physics_rate_hz)
    rows, outside = [], []
    for i, s in enumerate(slips):
        core = SoilWheels(1, hm, tables, dt, load_kg, damping_n_s_m=0.5 * load_kg / dt,
                          relaxation_m=max(soil.shear_modulus_m, 0.02),
                          lateral_relaxation_m=soil.lateral_shear_modulus_m)
        rows.append(run(core, radius_m=radius_m, load_kg=load_kg, gravity_m_s2=gravity_m_s2,
                        carriage_m_s=wheel_speed_m_s * (1.0 - s), wheel_rad_s=wheel_speed_m_s / radius_m,
                        dt_s=dt, steps=steps))
        outside.append(core.outside_model())  # the last step's contact
        report(progress, i + 1, len(slips))
    h, fx, t = (np.array(c) for c in zip(*rows, strict=True))
    return SoilCheck(soil.name, radius_m, width_m, load_n, np.asarray(slips, dtype=float), h, fx, t,
                     outside_model=np.array(outside, dtype=bool))
