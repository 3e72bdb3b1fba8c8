"""The ``coulomb`` tyre model's force law, engine-neutral: one Dahl-type bristle per wheel (Dahl 1968).

Each engine gathers a wheel's terrain contacts of the last step and its velocities, and applies the
force this law returns (offroadbench.sim.engines.pybullet.tyres for PyBullet,
offroadbench.sim.engines.mujoco.world for MuJoCo); the model and its limits are described there.
"""

from __future__ import annotations

import math

__all__ = ["CoulombBristles", "bristle_constants"]


def bristle_constants(share_kg: float, dt_s: float) -> tuple[float, float]:
    """(stiffness N/m, damping N s/m) of a wheel's bristle for its share ``share_kg`` of the mass at
    the trial's step ``dt_s``: ``k = m / (4 dt^2)`` and ``c = m / (2 dt)``, well inside the explicit
    step's stability bound (``k dt^2 / m < 1``, ``c dt / m < 2``); every engine's ``coulomb`` tyres."""
    return 0.25 * share_kg / dt_s**2, 0.5 * share_kg / dt_s


class CoulombBristles:
    """The engine-neutral core of the ``coulomb`` tyre model: one bristle per wheel.

    An engine's adapter (offroadbench.sim.engines.pybullet.tyres.CoulombTyres for PyBullet,
    offroadbench.sim.engines.mujoco.world for MuJoCo) sums each wheel's terrain contacts of the
    last step into :attr:`acc` (slot ``7 i``: the normal force, then the force-weighted point and
    normal, 3 each), marks the wheels touched in :attr:`touch`, and asks :meth:`wheel_force` for each touched wheel's friction force.
    ``mu`` is the tyre-terrain friction coefficient, ``stiffness_n_m`` and ``damping_n_s_m`` the
    bristle's tangential stiffness and damping per contact, ``dt_s`` the physics step.
    """

    def __init__(self, n_wheels: int, mu: float, dt_s: float, stiffness_n_m: float, damping_n_s_m: float) -> None:
        self.n = n_wheels
        self._mu = mu
        self._dt = dt_s
        self._k = stiffness_n_m
        self._c = damping_n_s_m
        # per-wheel state in flat lists, allocated once: each step only overwrites floats, so the
        # loop allocates no list or dict of its own (the engine's query results aside)
        self.acc = [0.0] * (7 * n_wheels)  # summed fn, fn * point (3), fn * normal (3)
        self._zero = [0.0] * (7 * n_wheels)
        self.touch = [False] * n_wheels  # the wheel has a loaded terrain contact this step
        self._bristle = [0.0] * (3 * n_wheels)  # bristle deflection, m
        self._held = [False] * n_wheels  # the wheel's bristle carries a deflection from the last step

    def reset(self) -> None:
        """Forget the bristle deflections (after the vehicle is teleported)."""
        held = self._held
        for i in range(self.n):
            held[i] = False

    def clear(self) -> None:
        """Start a step's contact sums: zero :attr:`acc` and :attr:`touch`."""
        self.acc[:] = self._zero
        touch = self.touch
        for i in range(self.n):
            touch[i] = False

    def release_untouched(self) -> None:
        """Forget the bristles of the wheels not touched this step."""
        touch, held = self.touch, self._held
        for i in range(self.n):
            if not touch[i]:
                held[i] = False

    def wheel_force(self, i: int, centre: tuple, lin: tuple, ang: tuple) -> tuple[float, float, float, float, float, float]:
        """(force x, y, z in N; point of application x, y, z in m), world frame, of touched wheel
        ``i`` whose centre of mass is at ``centre`` with linear velocity ``lin`` and angular
        velocity ``ang`` (world frame). Updates the wheel's bristle."""
        acc = self.acc
        b = 7 * i
        fn = acc[b]
        px, py, pz = acc[b + 1] / fn, acc[b + 2] / fn, acc[b + 3] / fn
        snx, sny, snz = acc[b + 4], acc[b + 5], acc[b + 6]
        norm = math.sqrt(snx * snx + sny * sny + snz * snz)
        nx, ny, nz = snx / norm, sny / norm, snz / norm  # on the terrain, pointing at the wheel
        cx, cy, cz = centre
        vx, vy, vz = lin
        wx, wy, wz = ang
        rx, ry, rz = px - cx, py - cy, pz - cz
        # velocity of the wheel's material point at the contact: v + w x r
        ux = vx + wy * rz - wz * ry
        uy = vy + wz * rx - wx * rz
        uz = vz + wx * ry - wy * rx
        un = ux * nx + uy * ny + uz * nz
        sx, sy, sz = ux - un * nx, uy - un * ny, uz - un * nz  # tangential slip
        bristle, j = self._bristle, 3 * i
        if self._held[i]:  # keep the stored deflection in the current tangent plane
            dx, dy, dz = bristle[j], bristle[j + 1], bristle[j + 2]
            dn = dx * nx + dy * ny + dz * nz
            dx, dy, dz = dx - dn * nx, dy - dn * ny, dz - dn * nz
        else:
            dx = dy = dz = 0.0
        dt, k, cdamp = self._dt, self._k, self._c
        dx, dy, dz = dx + sx * dt, dy + sy * dt, dz + sz * dt
        fx, fy, fz = -(k * dx + cdamp * sx), -(k * dy + cdamp * sy), -(k * dz + cdamp * sz)
        f = math.sqrt(fx * fx + fy * fy + fz * fz)
        limit = self._mu * fn
        if f > limit:  # sliding: the Coulomb limit, and the bristle at its stretched length
            s = limit / f
            fx, fy, fz = fx * s, fy * s, fz * s
            dx, dy, dz = -fx / k, -fy / k, -fz / k
        bristle[j], bristle[j + 1], bristle[j + 2] = dx, dy, dz
        self._held[i] = True
        return fx, fy, fz, px, py, pz
