"""The single-wheel soil rig on MuJoCo (offroadbench.sim.rigs.soil_check describes the rig): a
carriage (x slide joint), a free vertical slide carrying the load (z slide joint) and the wheel
(hinge about y), none of them colliding; the soil acts on the wheel through the shared force law
(:class:`~offroadbench.sim.tyre_laws.soil_wheels.SoilWheels`) as an external force and torque
(``xfrc_applied``), computed after ``mj_step1`` from the state of that step, as the MuJoCo world
applies its tyre forces. The carriage and wheel are velocity servos, ``kv`` large against their
masses and no force limit (the PyBullet rig's velocity motors, limited at 1e5 N / N m, never reach
it; a limit here would turn the stiff servo into a bang-bang one). The drawbar pull is the
carriage servo's force held back, the driving torque the wheel servo's.
"""

from __future__ import annotations

import mujoco

from offroadbench.sim.tyre_laws.soil_wheels import SoilWheels

__all__ = ["run_rig"]

#: the rig's masses as the PyBullet rig's: carriage 1 kg, wheel 1 g spinning with 0.05 kg m^2 about its axle (the
#: other two moments, 0.01 there, raised to 0.03 here: MuJoCo refuses inertias that break A + B >= C; the
#: wheel only spins about y, so they act on nothing)
_CARRIAGE_KG = 1.0
_WHEEL_KG = 1e-3
_WHEEL_INERTIA = "0.03 0.05 0.03"
#: the servos' gain in units of (effective mass / dt)
SERVO_GAIN = 1000.0


def _model(radius_m: float, load_kg: float, gravity_m_s2: float, dt_s: float) -> mujoco.MjModel:
    r = repr(float(radius_m))
    # kv: a stiff servo, SERVO_GAIN times the gain that would close a velocity error of its joint's
    # effective mass in one step, so the held speed is off by about 1 / SERVO_GAIN of the load's
    # share (the implicit-fast integrator keeps it stable)
    kv_x = SERVO_GAIN * (_CARRIAGE_KG + load_kg + _WHEEL_KG) / dt_s
    kv_w = SERVO_GAIN * 0.05 / dt_s
    xml = f"""
<mujoco model="soil-rig">
  <option timestep="{dt_s!r}" gravity="0 0 {-gravity_m_s2!r}" integrator="implicitfast"/>
  <worldbody>
    <body name="carriage" pos="0.5 0.1 {radius_m + 0.002!r}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass="{_CARRIAGE_KG!r}" diaginertia="1e-3 1e-3 1e-3"/>
      <body name="slide">
        <joint name="z" type="slide" axis="0 0 1"/>
        <inertial pos="0 0 0" mass="{load_kg!r}" diaginertia="1e-3 1e-3 1e-3"/>
        <body name="wheel">
          <joint name="spin" type="hinge" axis="0 1 0"/>
          <inertial pos="0 0 0" mass="{_WHEEL_KG!r}" diaginertia="{_WHEEL_INERTIA}"/>
          <geom type="sphere" size="{r}" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="carriage" joint="x" kv="{kv_x!r}"/>
    <velocity name="wheel" joint="spin" kv="{kv_w!r}"/>
  </actuator>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def run_rig(core: SoilWheels, *, radius_m: float, load_kg: float, gravity_m_s2: float, carriage_m_s: float,
            wheel_rad_s: float, dt_s: float, steps: int) -> tuple[float, float, float]:
    """Drive the rig for ``steps`` steps of ``dt_s``: the carriage at ``carriage_m_s``, the wheel at
    ``wheel_rad_s``; (sinkage m, drawbar pull N, driving torque N m), each the mean over the last
    quarter of the steps."""
    m = _model(radius_m, load_kg, gravity_m_s2, dt_s)
    d = mujoco.MjData(m)
    wheel = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "wheel")
    jx, jz, jw = (int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in ("x", "z", "spin"))
    d.ctrl[:] = (carriage_m_s, wheel_rad_s)
    mujoco.mj_forward(m, d)
    acc = []
    for k in range(steps):
        mujoco.mj_step1(m, d)
        core.begin()
        qvel = d.qvel.tolist()
        centre = tuple(d.xipos[wheel].tolist())
        out = core.wheel_force(0, centre, (0.0, 1.0, 0.0), (qvel[jx], 0.0, qvel[jz]), (0.0, qvel[jw], 0.0))
        d.xfrc_applied[wheel] = (*out[0], *out[1]) if out is not None else (0.0,) * 6
        mujoco.mj_step2(m, d)
        if k >= 3 * steps // 4:
            sink = core.last[0][0] if 0 in core.last else 0.0
            pull = -float(d.actuator_force[0])
            torque = float(d.actuator_force[1])
            acc.append((sink, pull, torque))
    return tuple(sum(c) / len(c) for c in zip(*acc, strict=True))
