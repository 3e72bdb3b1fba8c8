#!/usr/bin/env bash
# Issue 48's GPU checks, step 2 of 2, THERE (the device machine), from the repository root, as the
# last of the calls benchmarks/gpu/pack.sh prints; everything goes to $OUT/log.txt (comes back).
#
#   bash benchmarks/gpu/check.sh          # on the device: joins and installs the parts, then checks
#   bash benchmarks/gpu/check.sh --cpu    # here: the same steps, small, on Warp's CPU device with
#                                         # .venv's Python (a dry run of the script; no figure counts)
#
# The checks, each under its own time limit so that the call ends inside its 10 minutes:
#   1. the device: nvidia-smi, Warp's CUDA devices;
#   2. bench_batch.py --device cuda: world-steps/s and the host's share at 1024 / 4096 worlds (the
#      warm-up batch compiles the CUDA kernels: ~2 min cold), 256 twice with --hash (does the GPU
#      repeat itself? MuJoCo Warp 4.0 does not order contacts deterministically), and 256 with the
#      trial step's CUDA graph off (what the graph gains);
#   3. the paper study end to end (experiments/majhor2023-mujoco.toml on mujoco_warp, cuda,
#      --executor batched, the terrains built by one process per core): as one batch of 1,200
#      worlds, then split into 4 batches in 4 processes (--workers 4); each one's wall time and
#      success count per D beside the MuJoCo engine's committed results.
# Each step runs under its own limit and what is left of a 560 s budget (CHECK_BUDGET_S): a step
# the budget no longer holds is skipped, so the call ends inside its 10 minutes.
set -uo pipefail
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
out=${OUT:-/tmp/gpu-out}
mkdir -p "$out"
log=$out/log.txt
: > "$log"
say() { echo "== $* ($(date -u +%T))" | tee -a "$log"; }
deadline=$(( $(date +%s) + ${CHECK_BUDGET_S:-560} ))  # the device call's 10 minutes, less the transfers
run() {  # run LIMIT CMD...: under LIMIT seconds or what is left of the budget, whichever is less
  local limit=$1 left=$(( deadline - $(date +%s) )); shift
  [ "$left" -lt "$limit" ] && limit=$left
  if [ "$limit" -lt 20 ]; then echo "(skipped: the budget is spent) $*" | tee -a "$log"; return; fi
  timeout "$limit" "$@" 2>&1 | tee -a "$log"; echo "(exit ${PIPESTATUS[0]})" | tee -a "$log"
}

if [ "${1:-}" = --cpu ]; then
  py=$PWD/.venv/bin/python; ob=$PWD/.venv/bin/offroadbench; dev=cpu
  sizes=(2 4); twice=4; study_toml=experiments/smoke.toml; study_set=(); workers=2
  deadline=$(( $(date +%s) + 1200 ))
else
  dev=cuda
  mkdir -p /tmp/gpu
  for d in .gpu/p*/; do [ -f "$d/part" ] && cp "$d/part" "/tmp/gpu/$(basename "$d")"; done
  want=$(cat .gpu/p*/of | head -n1)
  have=$(ls /tmp/gpu | grep -c '^p[0-9][0-9]$')
  if [ "$have" != "$want" ]; then
    say "only $have of $want parts in /tmp/gpu ($(ls /tmp/gpu | tr '\n' ' ')): make the missing calls first"
    exit 3
  fi
  say "installing $want parts"
  cat /tmp/gpu/p[0-9][0-9] | tar -x -C /tmp/gpu || exit 3
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
    /tmp/gpu/wheels/*.whl 2>&1 | tail -n 3 | tee -a "$log"
  export PYTHONPATH=/tmp/site WARP_CACHE_PATH=/tmp/warp-cache
  py=python3; ob="python3 -c 'from offroadbench.cli import main; main()'"
  sizes=(1024 4096); twice=256; study_toml=experiments/majhor2023-mujoco.toml
  study_set=(--set sim.mujoco_warp.worlds=1200); workers=4
  say "device"
  run 30 nvidia-smi -L
fi
run 120 "$py" -c "import warp as wp, mujoco_warp, offroadbench; wp.init(); print('warp', wp.__version__, 'devices', [str(d) for d in wp.get_devices()]); print('offroadbench from', offroadbench.__file__)"

say "bench_batch: worlds ${sizes[*]} on $dev (the warm-up compiles)"
(cd benchmarks && run 300 "$py" bench_batch.py --device "$dev" --worlds "$(IFS=,; echo "${sizes[*]}")" --reference 0)
say "bench_batch: $twice worlds twice with digests, then with the CUDA graph off"
(cd benchmarks && run 150 "$py" bench_batch.py --device "$dev" --worlds "$twice,$twice" --reference 0 --hash)
(cd benchmarks && run 90 "$py" bench_batch.py --device "$dev" --worlds "$twice" --reference 0 --cuda-graph off)

study() {  # study OUTDIR [--workers N]: the study end to end, timed, its successes beside the committed run's
  local dir=$1; shift
  say "study end to end: $study_toml on mujoco_warp, $dev, --executor batched $*"
  rm -rf "$dir"
  local start; start=$(date +%s%N)
  run 240 bash -c "$ob study run $study_toml --set sim.engine=mujoco_warp --set sim.mujoco_warp.device=$dev ${study_set[*]} --executor batched $* --out $dir"
  echo "study wall: $(( ($(date +%s%N) - start) / 1000000 )) ms" | tee -a "$log"
  [ -f "$dir/report/summary.csv" ] || return
  run 60 "$py" - "$study_toml" "$dir" <<'PY'
import sys
from pathlib import Path
import pandas as pd
cols = ["group", "trials", "successes"]
new = pd.read_csv(Path(sys.argv[2]) / "report" / "summary.csv")[cols]
ref = Path("experiments/results") / Path(sys.argv[1]).stem / "summary.csv"
if ref.is_file():  # the committed run of the same study on its own engine
    new = new.merge(pd.read_csv(ref)[cols], on="group", suffixes=("", "_committed"))
print(new.to_string(index=False))
PY
}
study /tmp/gpu-study                       # one batch of every terrain (the builders: one per core)
cp /tmp/gpu-study/report/report.md "$out/study-report.md" 2>/dev/null
study /tmp/gpu-study-split --workers "$workers"   # the worlds split into batches, one process each
say "done"
