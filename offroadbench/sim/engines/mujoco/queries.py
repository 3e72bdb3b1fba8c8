"""Questions to a MuJoCo model and data on the host: a subtree's centre of mass, the height of a
height field under a point. Shared by the MuJoCo engine's world and the MuJoCo Warp engine's host
model (offroadbench.sim.engines.mujoco_warp.model), which asks them of its K terrains."""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["hfield_ray_height", "subtree_com"]


def subtree_com(model, data, body: int) -> tuple[float, float, float]:
    """The centre of mass of ``body``'s subtree in the world at ``data``'s joint positions, m
    (MuJoCo's kinematics and mj_comPos)."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    return tuple(data.subtree_com[body].tolist())


def hfield_ray_height(model, data, geom: int, x_m: float, y_m: float, top_m: float, *,
                      kinematics: bool = False) -> float:
    """Height of height-field ``geom``'s surface at (x, y) by a ray down from ``top_m``, m (NaN off
    the field); ``kinematics``: MuJoCo's kinematics first (after the geom's data was changed)."""
    if kinematics:
        mujoco.mj_kinematics(model, data)
    dist = mujoco.mj_rayHfield(model, data, geom, np.array([x_m, y_m, top_m]), np.array([0.0, 0.0, -1.0]))
    return float("nan") if dist < 0 else top_m - dist
