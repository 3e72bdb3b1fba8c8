"""Measurements of a loaded PyBullet vehicle body, from its links' bounding boxes, masses and states:
its geometry at load (offroadbench.sim.engine.VehicleGeometry), the height of its origin above its
lowest point (for a spawn) and its centre of mass. The questions
offroadbench.sim.engines.pybullet.world.World asks of its vehicle."""

from __future__ import annotations

import numpy as np
from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.sim.engine import VehicleGeometry

__all__ = ["bottom_offset_m", "centre_of_mass_m", "measure_geometry"]


def measure_geometry(cid: int, body: int, wheel_joints: list[int], excess_kg_m2: tuple[float, ...], mass_kg: float,
                     z_air_m: float) -> VehicleGeometry:
    """Vehicle ``body`` of client ``cid`` as loaded (offroadbench.sim.engine.VehicleGeometry): put in the
    air at (0, 0, ``z_air_m``), heading 0, wheels at joint angle 0, measured from the links' bounding
    boxes. ``excess_kg_m2``: each wheel's drive-train spin inertia beyond its link's, kg m^2;
    ``mass_kg``: the summed link masses."""
    base = [0.0, 0.0, z_air_m]
    pb.resetBasePositionAndOrientation(body, base, [0, 0, 0, 1], physicsClientId=cid)
    for j in wheel_joints:
        pb.resetJointState(body, j, 0.0, 0.0, physicsClientId=cid)
    n_links = pb.getNumJoints(body, physicsClientId=cid)
    boxes = [pb.getAABB(body, link, physicsClientId=cid) for link in range(-1, n_links)]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    wheels = [pb.getAABB(body, j, physicsClientId=cid) for j in wheel_joints]
    centres = [pb.getLinkState(body, j, physicsClientId=cid)[0] for j in wheel_joints]
    return VehicleGeometry(
        mass_kg=mass_kg,
        wheel_spin_inertia_kg_m2=tuple(pb.getDynamicsInfo(body, j, physicsClientId=cid)[2][1] + x
                                       for j, x in zip(wheel_joints, excess_kg_m2, strict=True)),
        wheel_centres_m=tuple((c[0] - base[0], c[1] - base[1], c[2] - base[2]) for c in centres),
        length_m=float(hi[0] - lo[0]),
        width_m=float(hi[1] - lo[1]),
        belly_m=float(boxes[0][0][2] - min(w[0][2] for w in wheels)),
        overhang=bool(boxes[0][1][0] > max(w[1][0] for w in wheels) + 1e-3),
    )


def bottom_offset_m(cid: int, body: int) -> float:
    """Height of ``body``'s base origin above the lowest point of its links in their current pose, m."""
    z_base = pb.getBasePositionAndOrientation(body, physicsClientId=cid)[0][2]
    lows = [pb.getAABB(body, link, physicsClientId=cid)[0][2]
            for link in range(-1, pb.getNumJoints(body, physicsClientId=cid))]
    return z_base - min(lows)


def centre_of_mass_m(cid: int, body: int) -> tuple[float, float, float]:
    """``body``'s centre of mass in the world, m (its links' centres weighted by their masses)."""
    total = pb.getDynamicsInfo(body, -1, physicsClientId=cid)[0]
    base = pb.getBasePositionAndOrientation(body, physicsClientId=cid)[0]
    acc = [total * base[0], total * base[1], total * base[2]]
    for link in range(pb.getNumJoints(body, physicsClientId=cid)):
        m = pb.getDynamicsInfo(body, link, physicsClientId=cid)[0]
        p = pb.getLinkState(body, link, physicsClientId=cid)[0]
        acc = [acc[0] + m * p[0], acc[1] + m * p[1], acc[2] + m * p[2]]
        total += m
    return acc[0] / total, acc[1] / total, acc[2] / total
