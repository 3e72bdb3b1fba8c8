"""Trial metrics as pure functions of telemetry arrays, as Majhor & Bos compute them (Sec. 2.4).

- Vertical acceleration: the vehicle's z position differentiated twice (second central
  difference of the 20 Hz samples), then its RMS.
- Pitch and roll rates: the unwrapped pitch (about the transverse axis) and roll (about the
  longitudinal axis), both from a level reference, differentiated once; then their RMS.
- Success rate, Eq. (5): ``100 * N_success / N_trials``.
- Soft soil (the ``terramechanics`` tyre model): the wheels' sinkage as the median and 95th
  percentile over the trial's *moving* samples, and the mean slip over the same samples. A moving
  sample is one where the vehicle is driven: the wheel-speed command or the base's horizontal
  speed is at least ``MOVING_SPEED_M_S``, which leaves out the vehicle settled at rest before the
  start and stopped at the goal but keeps a vehicle spinning its wheels in place. Not the maximum:
  the deepest sinkage of a trial is a transient spike (a wheel landing after a bump) in under 1 %
  of its samples, 2-3x the typical sinkage (issue 28).

Portability: every reduction here is plain Python on floats (``math.fsum``, ``math.hypot``) or an
element-wise IEEE operation (``np.diff``, division), never a BLAS call or a SIMD reduction whose
last bit may depend on the CPU, so a trial's metrics are the same bits on every x86-64 machine.

Angles: yaw, pitch and roll are Z-Y-X Tait-Bryan angles of the body (x forward, y left, z up),
so a level vehicle has zero roll and pitch whatever its heading. Pitch is the angle of the
longitudinal axis above the horizontal (nose up positive); roll is the rotation about the
longitudinal axis (left side up positive).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "roll_pitch_yaw_from_quat",
    "rms",
    "vertical_acceleration",
    "angle_rate",
    "rms_vertical_acceleration",
    "rms_angle_rate_deg_s",
    "path_length",
    "success_rate",
    "stuck_index",
    "MOVING_SPEED_M_S",
    "moving_samples",
    "percentile",
    "mean_where",
    "sinkage_summary",
]

#: a telemetry sample is "moving" when the wheel-speed command or the base's speed is this or more, m/s
MOVING_SPEED_M_S = 0.05


def roll_pitch_yaw_from_quat(quat_xyzw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Z-Y-X Euler angles (roll, pitch, yaw) in radians of quaternions (..., 4) in x, y, z, w order.

    Pitch is nose-up positive: the right-hand rotation about the body's y axis is nose-down
    positive, so the sign is flipped to make a climbing vehicle's pitch positive.
    """
    q = np.asarray(quat_xyzw, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    # rotation-matrix entries R[2,0], R[2,1], R[2,2], R[1,0], R[0,0]
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    r10 = 2.0 * (x * y + w * z)
    r00 = 1.0 - 2.0 * (y * y + z * z)
    roll = np.arctan2(r21, r22)
    pitch = np.arcsin(np.clip(r20, -1.0, 1.0))  # = -(ZYX pitch): nose-up positive
    yaw = np.arctan2(r10, r00)
    return roll, pitch, yaw


def rms(x: np.ndarray) -> float:
    """Root mean square of a 1-D array; NaN for an empty one."""
    a = np.asarray(x, dtype=float).ravel().tolist()
    return math.sqrt(math.fsum(v * v for v in a) / len(a)) if a else float("nan")


def vertical_acceleration(z_m: np.ndarray, dt_s: float) -> np.ndarray:
    """z differentiated twice: ``(z[i+1] - 2 z[i] + z[i-1]) / dt^2``, length n - 2 (m/s^2)."""
    return np.diff(np.asarray(z_m, dtype=float), 2) / (dt_s * dt_s)


def angle_rate(angle_rad: np.ndarray, dt_s: float) -> np.ndarray:
    """Unwrapped angle differentiated once: ``(a[i+1] - a[i]) / dt``, length n - 1 (rad/s)."""
    return np.diff(np.unwrap(np.asarray(angle_rad, dtype=float))) / dt_s


def rms_vertical_acceleration(z_m: np.ndarray, dt_s: float) -> float:
    """RMS vertical acceleration (m/s^2) of a uniformly sampled z series."""
    return rms(vertical_acceleration(z_m, dt_s))


def rms_angle_rate_deg_s(angle_rad: np.ndarray, dt_s: float) -> float:
    """RMS rate (deg/s) of a uniformly sampled angle series in radians (pitch or roll)."""
    return math.degrees(rms(angle_rate(angle_rad, dt_s)))


def path_length(xyz_m: np.ndarray) -> float:
    """Length of the polyline through the points (n, 2 or 3), metres."""
    p = np.asarray(xyz_m, dtype=float)
    if len(p) < 2:
        return 0.0
    return math.fsum(math.hypot(*d) for d in np.diff(p, axis=0).tolist())


def success_rate(successes) -> float:
    """Eq. (5): percentage of successful trials; NaN for no trials."""
    s = np.asarray(successes, dtype=bool)
    return float(100.0 * s.sum() / s.size) if s.size else float("nan")


def stuck_index(xy_m: np.ndarray, window: int, distance_m: float) -> int | None:
    """First sample index at which the vehicle has stayed within ``distance_m`` of the position
    ``window`` samples earlier for the whole window, or None.

    Paper Sec. 2.4: stuck if it fails to move more than 0.2 m within 30 s.
    """
    p = np.asarray(xy_m, dtype=float).tolist()
    for end in range(window, len(p)):
        x0, y0 = p[end - window]
        if all(math.hypot(x - x0, y - y0) < distance_m for x, y in p[end - window + 1 : end + 1]):
            return end
    return None


def moving_samples(cmd_v_m_s: np.ndarray, vx_m_s: np.ndarray, vy_m_s: np.ndarray,
                   threshold_m_s: float = MOVING_SPEED_M_S) -> np.ndarray:
    """Boolean mask of the samples where the vehicle is driven: |wheel-speed command| or the base's
    horizontal speed at least ``threshold_m_s`` (module docstring)."""
    cmd = np.abs(np.asarray(cmd_v_m_s, dtype=float))
    speed = np.hypot(np.asarray(vx_m_s, dtype=float), np.asarray(vy_m_s, dtype=float))
    return (cmd >= threshold_m_s) | (speed >= threshold_m_s)


def percentile(values, q: float) -> float:
    """The ``q``-th percentile (0-100) of the finite values, linear between order statistics (numpy's
    default ``linear`` method, written out in plain Python for portable bits); NaN when none."""
    v = sorted(x for x in np.asarray(values, dtype=float).ravel().tolist() if math.isfinite(x))
    if not v:
        return float("nan")
    pos = (len(v) - 1) * q / 100.0
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def mean_where(values, mask) -> float:
    """Mean of the finite ``values`` where ``mask`` holds (``math.fsum``); NaN when none."""
    v = [x for x, m in zip(np.asarray(values, dtype=float).tolist(), np.asarray(mask, dtype=bool).tolist(), strict=True)
         if m and math.isfinite(x)]
    return math.fsum(v) / len(v) if v else float("nan")


def sinkage_summary(sinkage_m, mask) -> tuple[float, float]:
    """(median, 95th percentile) of the sinkage samples where ``mask`` holds, m; NaN when none."""
    v = [x for x, m in zip(np.asarray(sinkage_m, dtype=float).tolist(), np.asarray(mask, dtype=bool).tolist(), strict=True) if m]
    return percentile(v, 50.0), percentile(v, 95.0)
