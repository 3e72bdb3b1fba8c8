"""Replays you can watch: one trial as a moving picture.

:class:`TrialView` is one figure: on the left the hillshade under the roughness class map (the
paper's Fig. 4 colours), the planned path (white, dashed), the path driven so far (black) and the
vehicle's footprint (its front edge white) where it is at that moment; on the right a strip of
speed, pitch and roll, and vertical acceleration (z differentiated twice, as the paper's metric,
Majhor & Bos 2023, Sec. 2.4) against time, with a cursor at that moment and the failure marked
(a red line at the time the trial ended, named by its failure reason).

:meth:`TrialView.draw` moves the view to telemetry sample ``i``; :func:`frame_indices` picks the
samples of an animation; ``offroadbench.io.animation.save_animation`` writes the frames with
matplotlib's animation writers (Pillow for GIF, ffmpeg for MP4). The Gymnasium env's
``render_mode="rgb_array"`` returns :meth:`TrialView.to_rgb` of the same view.

The view draws on a :class:`matplotlib.figure.Figure` (no pyplot state); :meth:`to_rgb` renders
it with the Agg canvas without touching the process's backend.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.patches import Polygon
from matplotlib.patheffects import Normal, Stroke

from offroadbench.heightmap import Heightmap
from offroadbench.navigation import metrics
from offroadbench.plots.style import class_cmap, new_figure
from offroadbench.plots.terrain import hillshade

__all__ = ["TrialView", "footprint_corners", "frame_indices", "strip_series"]

#: colour of the failure marks
FAIL_COLOUR = "#d62020"


def strip_series(tel: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The strip's curves from telemetry columns: time (s), horizontal speed and its command (m/s),
    pitch and roll (deg) and vertical acceleration (m/s^2; the second difference of z, padded with
    NaN at both ends so it lines up with the samples)."""
    t = np.asarray(tel["t_s"], dtype=float)
    az = np.full(t.shape, np.nan)
    if len(t) >= 3:
        dt = float(np.median(np.diff(t)))
        az[1:-1] = metrics.vertical_acceleration(tel["z_m"], dt)
    out = {
        "t_s": t,
        "speed_m_s": np.hypot(np.asarray(tel["vx_m_s"], float), np.asarray(tel["vy_m_s"], float)),
        "pitch_deg": np.degrees(np.asarray(tel["pitch_rad"], float)),
        "roll_deg": np.degrees(np.asarray(tel["roll_rad"], float)),
        "az_m_s2": az,
    }
    if "cmd_v_m_s" in tel:
        out["cmd_v_m_s"] = np.asarray(tel["cmd_v_m_s"], float)
    return out


def footprint_corners(x_m: float, y_m: float, yaw_rad: float, length_m: float, width_m: float) -> np.ndarray:
    """The four corners (4, 2) of the vehicle's footprint rectangle, front-left first,
    counter-clockwise: front-left, rear-left, rear-right, front-right."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    local = np.array([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]) * [length_m, width_m]
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + [x_m, y_m]


def frame_indices(n_samples: int, rate_hz: float, *, fps: float = 10.0, max_frames: int = 240,
                  hold_s: float = 1.5) -> list[int]:
    """Telemetry samples to show, one per frame: every ``k``-th sample so that the animation runs at
    real time or faster (``k = ceil(rate_hz / fps)``, raised until at most ``max_frames`` frames),
    always ending on the last sample, which is then held for ``hold_s`` seconds (the failure stays
    on screen)."""
    if n_samples < 1:
        return []
    step = max(1, math.ceil(rate_hz / fps))
    step = max(step, math.ceil(n_samples / max(1, max_frames - int(hold_s * fps))))
    idx = list(range(0, n_samples, step))
    if idx[-1] != n_samples - 1:
        idx.append(n_samples - 1)
    return idx + [n_samples - 1] * round(hold_s * fps)


def _crop(hm: Heightmap, xy: np.ndarray, pad_m: float, min_aspect: float = 0.7
          ) -> tuple[slice, slice, tuple[float, float, float, float]]:
    """Rows/cols of the map around the points (the shorter side widened to at least ``min_aspect``
    of the longer, so a straight path still shows its surroundings), and the crop's extent
    (x0, x1, y0, y1) in metres."""
    cell = hm.cell_size_m
    lo = np.nanmin(xy, axis=0) - pad_m
    hi = np.nanmax(xy, axis=0) + pad_m
    span = hi - lo
    want = np.maximum(span, min_aspect * span.max())
    mid = (lo + hi) / 2
    size = np.array([hm.width_m, hm.height_m])
    lo = np.clip(mid - want / 2, 0.0, None)
    hi = np.minimum(lo + want, size)
    lo = np.maximum(hi - want, 0.0)
    (x0, y0), (x1, y1) = lo, hi
    c0, c1 = math.floor(x0 / cell), math.ceil(x1 / cell) + 1
    r0, r1 = math.floor(y0 / cell), math.ceil(y1 / cell) + 1
    return slice(r0, r1), slice(c0, c1), (c0 * cell - cell / 2, (c1 - 1) * cell + cell / 2,
                                         r0 * cell - cell / 2, (r1 - 1) * cell + cell / 2)


class TrialView:
    """One trial's view, moved from sample to sample (see the module docstring).

    ``hm`` and ``classes`` (the closed class map, the heightmap's shape) are the terrain;
    ``path_xy`` the planned waypoints (N, 2); ``footprint_m`` the vehicle's (length, width);
    ``region_xy`` points the map panel must show (default: the path; the driven path is added by
    :meth:`draw` when it leaves the panel); ``t_max_s`` the time axis' end (default: the
    telemetry's last time); ``shade`` the map's hillshade if already computed.
    """

    def __init__(self, hm: Heightmap, classes: np.ndarray, path_xy: np.ndarray, *,
                 footprint_m: tuple[float, float], region_xy: np.ndarray | None = None,
                 t_max_s: float | None = None, title: str = "", pad_m: float = 2.5,
                 figsize: tuple[float, float] = (10.0, 5.4), dpi: int = 80, shade: np.ndarray | None = None) -> None:
        self.hm = hm
        self.footprint_m = footprint_m
        self.title = title
        self.t_max_s = t_max_s
        self.dpi = dpi
        path = np.asarray(path_xy, dtype=float).reshape(-1, 2)
        region = path if region_xy is None else np.vstack([path, np.asarray(region_xy, float).reshape(-1, 2)])
        rows, cols, extent = _crop(hm, region, pad_m)
        fig = new_figure(figsize=figsize)[0]
        fig.clear()
        self.fig = fig
        grid = fig.add_gridspec(3, 2, width_ratios=(1.1, 1.0))
        ax = fig.add_subplot(grid[:, 0])
        shade = hillshade(hm) if shade is None else shade
        ax.imshow(shade[rows, cols], cmap="gray", origin="lower", extent=extent, vmin=0, vmax=1,
                  interpolation="nearest")
        ax.imshow(np.asarray(classes)[rows, cols], cmap=class_cmap(), vmin=-0.5, vmax=2.5, origin="lower",
                  extent=extent, alpha=0.45, interpolation="nearest")
        ax.plot(path[:, 0], path[:, 1], color="white", lw=1.6, ls="--", label="planned",
                path_effects=[Stroke(linewidth=3.2, foreground="black"), Normal()])  # visible in the white legend
        ax.plot(*path[0], "o", color="limegreen", mec="black", ms=7, label="start")
        ax.plot(*path[-1], "o", color="red", mec="black", ms=7, label="goal")
        (self._trail,) = ax.plot([], [], color="black", lw=1.6, label="driven")
        self._body = Polygon(np.zeros((4, 2)), closed=True, facecolor="black", edgecolor="black", alpha=0.75,
                             zorder=5)
        ax.add_patch(self._body)
        (self._front,) = ax.plot([], [], color="white", lw=2.5, zorder=6, solid_capstyle="butt")
        (self._end,) = ax.plot([], [], "X", color=FAIL_COLOUR, mec="black", ms=12, zorder=7)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(loc="upper right", fontsize=7, framealpha=0.85)
        self._map = ax
        self._extent = extent
        self._strips = [fig.add_subplot(grid[i, 1]) for i in range(3)]
        labels = ("speed (m/s)", "angle (deg)", "vertical accel. (m/s^2)")
        for sub, label in zip(self._strips, labels, strict=True):
            sub.set_ylabel(label, fontsize=8)
            sub.grid(alpha=0.3)
            sub.tick_params(labelsize=7)
        self._strips[-1].set_xlabel("time (s)")
        for sub in self._strips[:-1]:
            sub.sharex(self._strips[-1])
            sub.tick_params(labelbottom=False)
        s0, s1, s2 = self._strips
        self._lines = {
            "cmd_v_m_s": s0.plot([], [], color="C2", lw=1, label="commanded")[0],
            "speed_m_s": s0.plot([], [], color="black", lw=1, label="horizontal speed")[0],
            "pitch_deg": s1.plot([], [], color="C0", lw=1, label="pitch")[0],
            "roll_deg": s1.plot([], [], color="C1", lw=1, label="roll")[0],
            "az_m_s2": s2.plot([], [], color="C4", lw=0.8, label="a_z")[0],
        }
        for sub in self._strips[:2]:
            sub.legend(loc="upper left", fontsize=7, framealpha=0.85)
        self._cursors = [sub.axvline(0.0, color="0.3", lw=0.8) for sub in self._strips]
        self._fail_lines = [sub.axvline(0.0, color=FAIL_COLOUR, lw=1.5, visible=False) for sub in self._strips]
        self._fail_text = s0.text(0.99, 0.95, "", transform=s0.transAxes, ha="right", va="top", fontsize=9,
                                  color=FAIL_COLOUR, fontweight="bold")
        self._head = fig.suptitle(title, fontsize=10)
        self._series: dict[str, np.ndarray] | None = None
        self._series_of: object = None

    def draw(self, tel: Mapping[str, np.ndarray], i: int | None = None, *, failure_reason: str | None = None) -> None:
        """Show sample ``i`` (default: the last) of ``tel`` (telemetry columns: at least t_s, x_m, y_m,
        z_m, yaw_rad, roll_rad, pitch_rad, vx_m_s, vy_m_s). ``failure_reason`` (a trial's final
        reason, "" for success) is marked once ``i`` is the last sample."""
        if self._series_of is not tel:  # the strip's curves, once per telemetry
            self._series = strip_series(tel)
            self._series_of = tel
            self._fit_strips()
        s = self._series
        n = len(s["t_s"])
        i = n - 1 if i is None else int(i)
        x = np.asarray(tel["x_m"], float)
        y = np.asarray(tel["y_m"], float)
        self._trail.set_data(x[: i + 1], y[: i + 1])
        length, width = self.footprint_m
        corners = footprint_corners(x[i], y[i], float(tel["yaw_rad"][i]), length, width)
        self._body.set_xy(corners)
        self._front.set_data(corners[[0, 3], 0], corners[[0, 3], 1])
        for key, line in self._lines.items():
            if key in s:
                line.set_data(s["t_s"][: i + 1], s[key][: i + 1])
        t = float(s["t_s"][i])
        for c in self._cursors:
            c.set_xdata([t, t])
        last = i == n - 1 and failure_reason is not None
        failed = last and failure_reason != ""
        for f in self._fail_lines:
            f.set_xdata([t, t])
            f.set_visible(failed)
        self._end.set_data(([x[i]], [y[i]]) if failed else ([], []))
        self._fail_text.set_text(f"{failure_reason} at {t:.1f} s" if failed else ("success" if last else ""))
        self._fail_text.set_color(FAIL_COLOUR if failed else "green")
        head = f"{self.title}   " if self.title else ""
        self._head.set_text("\n".join(textwrap.wrap(f"{head}t = {t:5.1f} s", 120)))  # a long label wraps

    def _fit_strips(self) -> None:
        s = self._series
        t_end = float(s["t_s"][-1]) if len(s["t_s"]) else 1.0
        t_max = max(self.t_max_s or 0.0, 1.03 * t_end, 1e-3)  # room for the failure line at the end
        self._strips[-1].set_xlim(0.0, t_max)
        groups = (("speed_m_s", "cmd_v_m_s"), ("pitch_deg", "roll_deg"), ("az_m_s2",))
        for sub, keys in zip(self._strips, groups, strict=True):
            vals = np.concatenate([s[k][np.isfinite(s[k])] for k in keys if k in s] or [np.zeros(1)])
            lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
            if keys[0] == "speed_m_s":
                lo = min(lo, 0.0)
            span = max(hi - lo, 1e-3)
            sub.set_ylim(lo - 0.08 * span, hi + 0.08 * span)

    def pixel_of(self, x_m: float, y_m: float) -> tuple[int, int]:
        """(row, column) of map point (x, y) in the image of :meth:`to_rgb` (row 0 at the top)."""
        self.fig.set_dpi(self.dpi)
        px, py = self._map.transData.transform((x_m, y_m))
        height = self.fig.bbox.height
        return round(height - py), round(px)

    def to_rgb(self) -> np.ndarray:
        """The view as a uint8 RGB image (H, W, 3), rendered with the Agg canvas."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        canvas = self.fig.canvas if isinstance(self.fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(self.fig)
        self.fig.set_dpi(self.dpi)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def record_columns() -> Sequence[str]:
    """The telemetry columns :meth:`TrialView.draw` reads."""
    return ("t_s", "x_m", "y_m", "z_m", "yaw_rad", "roll_rad", "pitch_rad", "vx_m_s", "vy_m_s", "cmd_v_m_s")
