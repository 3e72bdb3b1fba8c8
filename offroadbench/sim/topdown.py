"""The top-down pixel map of a traversal: the closed roughness-class map with the planned path, the
goal and the vehicle's footprint, as uint8 RGB (the Gymnasium env's older, cheaper view than its
replay render; offroadbench.sim.gym_env)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["top_down_image"]

#: low / semi / high class colours (offroadbench.plots.style's palette), RGB
_CLASS_RGB = np.array([[0x1F, 0x5F, 0xBF], [0xF0, 0x8C, 0x1A], [0xF5, 0xE5, 0x2A]], dtype=np.uint8)  # plots.style


def top_down_image(classes: np.ndarray, cell_m: float, pos, yaw: float, length_m: float, width_m: float, goal_xy,
                   path_xy: np.ndarray | None = None, max_side: int = 256) -> np.ndarray:
    """Class map (north up: row 0 of the image is the largest y) with the path, goal and vehicle,
    as uint8 RGB, at most ``max_side`` pixels a side."""
    step = max(1, int(math.ceil(max(classes.shape) / max_side)))
    img = _CLASS_RGB[np.asarray(classes)[::step, ::step]].copy()
    px = cell_m * step
    rows, cols = img.shape[:2]

    def paint(xy: np.ndarray, colour) -> None:
        c = np.rint(xy[:, 0] / px).astype(int)
        r = np.rint(xy[:, 1] / px).astype(int)
        ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        img[r[ok], c[ok]] = colour

    if path_xy is not None and len(path_xy) > 1:
        seg = [a + (b - a) * t for a, b in zip(path_xy[:-1], path_xy[1:], strict=True)
               for t in np.linspace(0, 1, max(2, int(np.hypot(*(b - a)) / px) + 1))[:, None]]
        paint(np.vstack(seg).reshape(-1, 2), (255, 255, 255))
    gy, gx = np.mgrid[-2:3, -2:3]
    paint(np.column_stack([goal_xy[0] + gx.ravel() * px, goal_xy[1] + gy.ravel() * px]), (220, 20, 20))
    u = np.linspace(-0.5, 0.5, max(3, int(length_m / px) * 2))
    v = np.linspace(-0.5, 0.5, max(3, int(width_m / px) * 2))
    uu, vv = np.meshgrid(u * length_m, v * width_m)
    cos, sin = math.cos(yaw), math.sin(yaw)
    body = np.column_stack([pos[0] + cos * uu.ravel() - sin * vv.ravel(), pos[1] + sin * uu.ravel() + cos * vv.ravel()])
    paint(body, (0, 0, 0))
    front = uu.ravel() > 0.3 * length_m
    paint(body[front], (255, 255, 255))
    return np.ascontiguousarray(img[::-1])
