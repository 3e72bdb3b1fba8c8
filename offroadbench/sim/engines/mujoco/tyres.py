"""The tyre and soil forces of the MuJoCo world: its contacts read after ``mj_step1``, the project's
tyre model (CoulombBristles) and soil model applied as ``xfrc_applied``, in Python or through the
compiled loops (offroadbench.sim.engines.mujoco._tyres_c, ``_soil_c``)."""

from __future__ import annotations

import mujoco
import numpy as np


class MuJoCoTyres:
    """The tyre half of offroadbench.sim.engines.mujoco.world.MuJoCoWorld: contacts in, forces out."""

    def advance(self, n: int) -> None:
        """``n`` trial steps (:meth:`step` ``n`` times, the same bits): with the compiled whole step
        and the tyres at each MuJoCo step, one compiled call of ``n * substeps`` MuJoCo steps (the
        trial loop's steps between two control ticks: offroadbench.sim.trial.runner.TrialLoop)."""
        if n > 1 and self._steps_call is not None and self._base_force is None:
            self._steps_call(n * self.substeps, True)
            return
        for _ in range(n):
            self.step()

    def _step_compiled(self) -> None:
        """:meth:`step` with the compiled tyre loop (offroadbench.sim.engines.mujoco._tyres_c): the same
        sequence, the contacts read and the forces applied outside the interpreter; where MuJoCo's
        struct layout checks out, the whole trial step, MuJoCo's calls included, in one compiled call
        (``_tyres_c.step_trial``)."""
        m, d = self.model, self.data
        tc, f, ist = self._fast
        each = self.contact.tyres_each_substep
        last = self.substeps - 1
        pushed = self._base_force
        push = 14 * len(self._loads) + tc.F_PUSH_X
        if pushed is not None:
            f[push:push + 3] = pushed
            f[push + 3] = 1.0
        qvel, xmat, xipos, xfrc = self._step_arrays
        whole = self._fast_step
        if whole is not None:  # no Python between MuJoCo's calls: one compiled call per trial step
            tc.STEP(whole[0], whole[1], whole[2], whole[3], whole[4], qvel, xmat, xipos, xfrc, f, ist, self.substeps, each)
            if pushed is not None:
                self._base_force = None
                f[push + 3] = 0.0
            return
        step1, step2, apply, read = mujoco.mj_step1, mujoco.mj_step2, tc.APPLY, tc.READ
        for k in range(self.substeps):
            if each or k == 0:
                step1(m, d)
                apply(qvel, xmat, xipos, xfrc, f, ist)
                step2(m, d)
            else:
                mujoco.mj_step(m, d)  # the tyre forces of this trial step held in xfrc_applied
            if each or k == last:
                con = d.contact
                read(con.geom, con.dist, con.pos, con.frame, con.efc_address, d.efc_force, f, ist)
        if pushed is not None:
            self._base_force = None
            f[push + 3] = 0.0

    def _step_soil_compiled(self) -> None:
        """:meth:`step` with the compiled soil loop (offroadbench.sim.engines.mujoco._soil_c): the same
        sequence, the soil forces applied outside the interpreter. No contact is read: the wheels
        do not collide under the soil model (their loads stay zero, as the Python loop reads them),
        and the soil's sinkage and slip come from the loop's state. The whole trial step, MuJoCo's
        calls included, in one compiled call (``_soil_step_c.step_trial_soil``)."""
        m, d = self.model, self.data
        sc, f, ist, tab = self._fast_soil
        each = self.contact.tyres_each_substep
        pushed = self._base_force
        push = 8 * len(self._loads) + sc.F_PUSH_X
        if pushed is not None:
            f[push:push + 3] = pushed
            f[push + 3] = 1.0
        whole = self._fast_soil_step
        if whole is not None:  # no Python between MuJoCo's calls: one compiled call per trial step
            qvel, xmat, xipos, xfrc = self._step_arrays
            whole[0](whole[1], whole[2], whole[3], whole[4], qvel, xmat, xipos, xfrc, f, ist, tab, self.substeps, each)
            if pushed is not None:
                self._base_force = None
                f[push + 3] = 0.0
            return
        qvel, xmat, xipos, xfrc = d.qvel, d.xmat, d.xipos, d.xfrc_applied
        step1, step2, apply = mujoco.mj_step1, mujoco.mj_step2, sc.APPLY
        for k in range(self.substeps):
            if each or k == 0:
                step1(m, d)
                apply(qvel, xmat, xipos, xfrc, f, ist, tab)
                step2(m, d)
            else:
                mujoco.mj_step(m, d)  # the soil forces of this trial step held in xfrc_applied
        if pushed is not None:
            self._base_force = None
            f[push + 3] = 0.0

    def _apply_tyres(self) -> None:
        """The tyre forces (``coulomb``: of the wheels touched in the last step; ``terramechanics``:
        of every wheel on the soil), as forces and torques about each wheel's centre of mass in
        ``xfrc_applied`` (one write of all rows)."""
        d, core = self.data, self._tyres
        xfrc = self._xfrc
        xfrc[:] = self._xfrc_zero
        if self._base_force is not None:
            k = 6 * self._chassis
            xfrc[k:k + 3] = self._base_force
        if self._soil is not None:
            self._soil_forces(xfrc)
        elif any(core.touch):
            touch = core.touch
            qvel = d.qvel.tolist()
            r = d.xmat[self._chassis].tolist()
            xipos = d.xipos.tolist()
            v0, v1, v2 = qvel[0:3]
            wb0, wb1, wb2 = qvel[3:6]
            w0 = r[0] * wb0 + r[1] * wb1 + r[2] * wb2
            w1 = r[3] * wb0 + r[4] * wb1 + r[5] * wb2
            w2 = r[6] * wb0 + r[7] * wb1 + r[8] * wb2
            c0 = xipos[self._chassis]
            for i, b in enumerate(self._wheel_bodies):
                if not touch[i]:
                    continue
                c = xipos[b]
                if self._articulated:  # the wheel body's own velocity (steering, rockers, bogies)
                    vel = np.zeros(6)
                    mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
                    fx, fy, fz, px, py, pz = core.wheel_force(i, c, tuple(vel[3:].tolist()), tuple(vel[:3].tolist()))
                    ox, oy, oz = px - c[0], py - c[1], pz - c[2]
                    k = 6 * b
                    xfrc[k:k + 6] = (fx, fy, fz, oy * fz - oz * fy, oz * fx - ox * fz, ox * fy - oy * fx)
                    continue
                rx, ry, rz = c[0] - c0[0], c[1] - c0[1], c[2] - c0[2]
                lin = (v0 + w1 * rz - w2 * ry, v1 + w2 * rx - w0 * rz, v2 + w0 * ry - w1 * rx)
                a0, a1, a2 = self._axis_world(i, r)
                s = qvel[self._wheel_qvel[i]]
                fx, fy, fz, px, py, pz = core.wheel_force(i, c, lin, (w0 + a0 * s, w1 + a1 * s, w2 + a2 * s))
                ox, oy, oz = px - c[0], py - c[1], pz - c[2]
                k = 6 * b
                xfrc[k:k + 6] = (fx, fy, fz, oy * fz - oz * fy, oz * fx - ox * fz, ox * fy - oy * fx)
        d.xfrc_applied.flat[:] = xfrc

    def _soil_forces(self, xfrc: list) -> None:
        """The soil's force and torque on each wheel (offroadbench.sim.tyre_laws.soil_wheels) into
        ``xfrc`` rows, from the wheels' poses and velocities now. The force acts at the wheel's centre
        of mass, taken as its centre (both shipped vehicles' wheels have it on the axle)."""
        d, soil = self.data, self._soil
        qvel = d.qvel.tolist()
        r = d.xmat[self._chassis].tolist()
        xipos = d.xipos.tolist()
        v0, v1, v2 = qvel[0:3]
        wb0, wb1, wb2 = qvel[3:6]
        w0 = r[0] * wb0 + r[1] * wb1 + r[2] * wb2
        w1 = r[3] * wb0 + r[4] * wb1 + r[5] * wb2
        w2 = r[6] * wb0 + r[7] * wb1 + r[8] * wb2
        c0 = xipos[self._chassis]
        soil.begin()
        for i, b in enumerate(self._wheel_bodies):
            c = xipos[b]
            if self._articulated:  # the wheel body's own velocity and axle (steering, rockers, bogies)
                vel = np.zeros(6)
                mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
                axis = tuple(d.xaxis[self._wheel_jnt[i]].tolist())
                out = soil.wheel_force(i, c, axis, tuple(vel[3:].tolist()), tuple(vel[:3].tolist()))
                if out is not None:
                    k = 6 * b
                    xfrc[k:k + 6] = (*out[0], *out[1])
                continue
            rx, ry, rz = c[0] - c0[0], c[1] - c0[1], c[2] - c0[2]
            lin = (v0 + w1 * rz - w2 * ry, v1 + w2 * rx - w0 * rz, v2 + w0 * ry - w1 * rx)
            a0, a1, a2 = self._axis_world(i, r)
            s = qvel[self._wheel_qvel[i]]
            out = soil.wheel_force(i, c, (a0, a1, a2), lin, (w0 + a0 * s, w1 + a1 * s, w2 + a2 * s))
            if out is not None:
                k = 6 * b
                xfrc[k:k + 6] = (*out[0], *out[1])

    def _axis_world(self, i: int, r: list) -> tuple[float, float, float]:
        a = self._wheel_axis[i]  # in the chassis frame (the wheels hang straight off it)
        return (r[0] * a[0] + r[1] * a[1] + r[2] * a[2],
                r[3] * a[0] + r[4] * a[1] + r[5] * a[2],
                r[6] * a[0] + r[7] * a[1] + r[8] * a[2])

    def _read_contacts(self) -> None:
        """Each wheel's terrain contacts of the step just taken: normal loads, penetration, and the
        tyre model's sums (normal force, force-weighted point and normal)."""
        d = self.data
        n = d.ncon
        loads = self._loads
        for i in range(len(loads)):
            loads[i] = 0.0
        self._penetration = 0.0
        core = self._tyres
        if core is not None:
            core.clear()
        if n == 0:
            if core is not None:
                core.release_untouched()
            return
        con = d.contact
        geoms = con.geom[:n].tolist()
        dists = con.dist[:n].tolist()
        pos = con.pos[:n].tolist()
        frames = con.frame[:n].tolist()
        adr = con.efc_address[:n].tolist()
        efc = d.efc_force
        terrain, wheel_geom = self._terrain_geom, self._wheel_geom
        coulomb = core is not None
        acc = core.acc if coulomb else None
        touch = core.touch if coulomb else None
        force = np.zeros(6)
        deepest = 0.0
        for k in range(n):
            g1, g2 = geoms[k]
            if g1 == terrain:
                slot, sign = wheel_geom.get(g2), 1.0
            elif g2 == terrain:
                slot, sign = wheel_geom.get(g1), -1.0
            else:
                continue
            if slot is None:
                continue
            if -dists[k] > deepest:
                deepest = -dists[k]
            if adr[k] < 0:
                continue
            if coulomb:
                fn = float(efc[adr[k]])
            else:
                mujoco.mj_contactForce(self.model, d, k, force)
                fn = float(force[0])
            if fn <= 0.0:
                continue
            loads[slot] += fn
            if coulomb:
                p, f = pos[k], frames[k]
                b = 7 * slot
                touch[slot] = True
                acc[b] += fn
                acc[b + 1] += fn * p[0]
                acc[b + 2] += fn * p[1]
                acc[b + 3] += fn * p[2]
                acc[b + 4] += fn * sign * f[0]
                acc[b + 5] += fn * sign * f[1]
                acc[b + 6] += fn * sign * f[2]
        self._penetration = deepest
        if coulomb:
            core.release_untouched()
