#!/usr/bin/env bash
# Issue 48's GPU checks, step 1 of 2, HERE (no GPU needed): the wheels the device machine lacks,
# for its Python 3.12, cut into parts that travel one per `run` call. See benchmarks/gpu/README.md.
#
#   bash benchmarks/gpu/pack.sh          # in the checkout the session started in (the one `run` sends)
#
# What the device machine lacks (its image has numpy, scipy, pandas, matplotlib, numba, pyarrow,
# tqdm, pillow, threadpoolctl, markdown-it-py, etils, absl-py; no pybullet, which a batched study
# does not import): offroadbench itself (a wheel of this checkout), mujoco + mujoco-core, glfw,
# pyopengl, mujoco-warp, warp-lang (149 MB), ruckig, greenlet, finufft; the versions of this
# checkout's .venv. A call carries at most 64 MiB with the working tree, so the parts are cut
# to what the tree leaves (~21 MiB beside a 41 MB tree: about 9 calls).
set -euo pipefail
root=$(git rev-parse --show-toplevel)
cd "$root"
py=${PY:-.venv/bin/python}
exclude=$(git rev-parse --git-path info/exclude)
mkdir -p "$(dirname "$exclude")"
grep -qxF '/.gpu/' "$exclude" 2>/dev/null || echo '/.gpu/' >> "$exclude"
rm -rf .gpu && mkdir -p .gpu/wheels
pins=()
for name in mujoco mujoco-core glfw pyopengl mujoco-warp warp-lang ruckig greenlet finufft; do
  pins+=("$name==$("$py" -c "import importlib.metadata as m, sys; print(m.version(sys.argv[1]))" "$name")")
done
plat=()
for p in manylinux_2_28_x86_64 manylinux_2_27_x86_64 manylinux_2_24_x86_64 manylinux_2_17_x86_64 manylinux2014_x86_64; do
  plat+=(--platform "$p")
done
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp "${plat[@]}" \
  -d .gpu/wheels "${pins[@]}"
"$py" -m pip wheel -q --no-deps -w .gpu/wheels . >/dev/null
tree=$(git ls-files -z | xargs -0 du -cb | tail -n1 | cut -f1)
part=$(( (64 * 1024 * 1024 - tree) - 3 * 1024 * 1024 ))
[ "$part" -gt $((4 * 1024 * 1024)) ] || { echo "pack.sh: the working tree ($tree bytes) leaves no room for the wheels" >&2; exit 2; }
tar -C .gpu -cf - wheels | split -b "$part" -d -a 2 - .gpu/part.
rm -rf .gpu/wheels
parts=(.gpu/part.*)
for f in "${parts[@]}"; do
  n=${f##*.}
  mkdir -p ".gpu/p$n"
  mv "$f" ".gpu/p$n/part"
  echo "${#parts[@]}" > ".gpu/p$n/of"
done
last=$(printf 'p%02d' $(( ${#parts[@]} - 1 )))
echo "pack.sh: ${#parts[@]} parts of at most $part bytes in .gpu/ (${pins[*]}, offroadbench)."
echo "Make these device calls one right after the other (the machine stays warm ~30 s between calls):"
for f in .gpu/p*; do
  n=$(basename "$f")
  [ "$n" = "$last" ] && break
  echo "  run(carry=[\".gpu/$n\"], command=\"mkdir -p /tmp/gpu && cp .gpu/$n/part /tmp/gpu/$n && ls /tmp/gpu\", timeout_s=60)"
done
echo "  run(carry=[\".gpu/$last\"], command=\"bash benchmarks/gpu/check.sh\", timeout_s=590)"
