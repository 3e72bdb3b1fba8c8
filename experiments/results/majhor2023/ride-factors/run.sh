#!/usr/bin/env bash
# Ride-metric factors (issue 28 item 6): drive paper-d2.45 at D_high 2.3 and 2.6, terrains of root
# seeds 11 and 12, 6 missions each, telemetry at 60 Hz (20 and 10 Hz are taken from it), once per
# configuration. Usage: run.sh OUT NAME [--set KEY=VALUE ...]; analyse with analyse.py OUT.
# The "old loop" row ran the same command on the code before issue 28 (commit 2979732).
set -euo pipefail
out=$1; name=$2; shift 2
for D in 2.3 2.6; do for seed in 11 12; do
  offroadbench drive paper-d2.45 --missions 6 --seed "$seed" --out "$out/$name/D${D}_s${seed}" \
    --set "layers.base.D_high=$D" --set sim.telemetry_rate_hz=60 "$@"
done; done
# configurations of the table:
#   new:     (no --set)              slow:   --set controller.cruise_speed_m_s=0.5
#   phys120: --set sim.physics_rate_hz=120
#   soft:    --set vehicle.tyre_stiffness_n_m=30000 --set vehicle.tyre_damping_n_s_m=1300
#   stiff:   --set vehicle.tyre_stiffness_n_m=300000 --set vehicle.tyre_damping_n_s_m=4100
