"""Ride metrics' sensitivity to D per configuration (issue 28 item 6; run.sh drives the trials).

For each configuration: the median over the successful trials at D_high 2.3 and at 2.6 of the RMS
vertical acceleration and the RMS pitch rate (offroadbench.navigation.metrics, as a trial computes
them), their change 2.3 -> 2.6 and its 90 % bootstrap interval (trials resampled within each D).
Telemetry is recorded at 60 Hz; 20 Hz (the paper's) is every 3rd sample, 10 Hz every 6th. The sensor
place is a point fixed on the chassis at an offset from the base origin (its z from the pose).

Usage: python analyse.py OUT  (OUT as given to run.sh); prints the table and writes OUT/table.csv.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from offroadbench.io.telemetry import load_telemetry
from offroadbench.navigation import metrics

RATE_HZ = 60
CONFIGS = [  # (row, run name, telemetry decimation, sensor offset x fwd / y left / z up, m)
    ("baseline: new speed loop, 1 m/s, 60 Hz physics, 20 Hz telemetry, sensor at the base origin", "new", 3, (0, 0, 0)),
    ("old speed loop (re-planned from the measured speed each tick)", "old", 3, (0, 0, 0)),
    ("telemetry 60 Hz", "new", 1, (0, 0, 0)),
    ("telemetry 10 Hz", "new", 6, (0, 0, 0)),
    ("sensor 0.3 m ahead of the base origin", "new", 3, (0.3, 0, 0)),
    ("sensor 0.3 m behind", "new", 3, (-0.3, 0, 0)),
    ("sensor 0.3 m above", "new", 3, (0, 0, 0.3)),
    ("cruise speed 0.5 m/s", "slow", 3, (0, 0, 0)),
    ("physics 120 Hz", "phys120", 3, (0, 0, 0)),
    ("tyre 30 kN/m, 1.3 kN s/m (softer)", "soft", 3, (0, 0, 0)),
    ("tyre 300 kN/m, 4.1 kN s/m (stiffer)", "stiff", 3, (0, 0, 0)),
]


def sensor_z(tel: dict, offset) -> np.ndarray:
    """z of the chassis point at ``offset`` (body frame), m: base z plus the third row of R times it."""
    x, y, z, w = tel["qx"], tel["qy"], tel["qz"], tel["qw"]
    ox, oy, oz = offset
    return (tel["z_m"] + 2 * (x * z - w * y) * ox + 2 * (y * z + w * x) * oy
            + (1 - 2 * (x * x + y * y)) * oz)


def trial_values(run: Path, every: int, offset) -> np.ndarray:
    """(RMS vertical acceleration, RMS pitch rate) of each successful trial under ``run``."""
    out = []
    for d in sorted(run.parent.glob(run.name + "_s*")):
        trials = pd.read_csv(d / "trials.csv")
        for r in trials[trials["success"].astype(bool)].itertuples():
            tel = load_telemetry(d / "telemetry" / f"mission_{int(r.mission_index):03d}.parquet")
            dt = every / RATE_HZ
            out.append((metrics.rms_vertical_acceleration(sensor_z(tel, offset)[::every], dt),
                        metrics.rms_angle_rate_deg_s(tel["pitch_rad"][::every], dt)))
    return np.array(out)


def change_interval(a: np.ndarray, b: np.ndarray, n: int = 2000) -> tuple[float, float]:
    """90 % bootstrap interval of median(b) - median(a)."""
    rng = np.random.default_rng(0)
    d = [np.median(rng.choice(b, len(b))) - np.median(rng.choice(a, len(a))) for _ in range(n)]
    return tuple(np.percentile(d, [5, 95]))


def table(out: Path) -> pd.DataFrame:
    rows = []
    for label, name, every, offset in CONFIGS:
        a, b = (trial_values(out / name / f"D{d}", every, offset) for d in ("2.3", "2.6"))
        if a.ndim != 2 or b.ndim != 2:
            continue
        row = {"configuration": label, "n (2.3/2.6)": f"{len(a)}/{len(b)}"}
        for col, key, fmt in ((0, "az", "{:+.2f}"), (1, "pitch", "{:+.1f}")):
            lo, hi = change_interval(a[:, col], b[:, col])
            m23, m26 = float(np.median(a[:, col])), float(np.median(b[:, col]))
            row |= {f"{key} 2.3": m23, f"{key} 2.6": m26, f"{key} change": m26 - m23,
                    f"{key} 90 %": f"[{fmt.format(lo)}, {fmt.format(hi)}]"}
        rows.append(row)
    return pd.DataFrame(rows)


if __name__ == "__main__":
    out = Path(sys.argv[1])
    df = table(out)
    df.to_csv(out / "table.csv", index=False)
    print(df.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
