#!/usr/bin/env bash
# The wall cases of issue 52, item 2 (scripts/wall_cases.py; docs/walls.md, "Staircase walls
# against the converged reference") on the GPU machine. Runs over a copy of the repo with
# .carry/gpu as `ROCKPREP=1 BUILD_DIR=build bash scripts/gpu/build_bundle.sh` makes it (rockflow,
# rockprep, .carry/gpu/lib and rockprep-libs.tar.xz; a bins.tar.xz there is unpacked too).
# rockprep packs each case there (tile sets are built on the GPU when missing), rockflow sweeps
# it on the GPU, rockflow lbm runs the ladder on the machine's cores. Arguments go to
# wall_cases.py, after its defaults here (--size gpu --backend cuda --threads $(nproc)); e.g.
#   bash scripts/gpu/wall_cases.sh --rc-per-voxel 1.0,2.0
# The light outputs (wall_cases.json, every log, sweep.json/csv, lbm.json, run.json) come back in
# $OUT/wall_cases; the particle files stay in /tmp/wall_cases.
set -uo pipefail
cd "$(dirname "$0")/../.."
bin=$PWD/.carry/gpu/bin
mkdir -p "$bin"
[ -f .carry/gpu/bins.tar.xz ] && tar xJf .carry/gpu/bins.tar.xz -C "$bin"
if [ -f .carry/gpu/rockprep-libs.tar.xz ]; then
  mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
fi
export LD_LIBRARY_PATH="$PWD/.carry/gpu/lib:/tmp/rockprep-libs:${LD_LIBRARY_PATH:-}"
for tool in rockprep rockflow; do
  if [ ! -x "$bin/$tool" ]; then
    echo "wall_cases.sh: $bin/$tool is missing (ROCKPREP=1 BUILD_DIR=build bash scripts/gpu/build_bundle.sh)" >&2
    exit 2
  fi
done
out=${OUT:-/tmp/out}
work=/tmp/wall_cases
mkdir -p "$out/wall_cases" "$work"
{
  echo "date: $(date -u +%Y-%m-%dT%H:%MZ)  commit: $(cat .carry/gpu/COMMIT 2>/dev/null)"
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  echo "cpu: $(nproc) cores"
} | tee "$out/wall_cases/machine.txt"
python3 scripts/wall_cases.py --size gpu --backend cuda --threads "$(nproc)" --bin "$bin" \
  --out "$work" "$@" 2>&1 | tee "$out/wall_cases/wall_cases.txt"
rc=${PIPESTATUS[0]}
(cd "$work" && find . \( -name '*.json' -o -name '*.log' -o -name '*.csv' -o -name '*.txt' \) \
  -print0 | tar cf - --null -T - | tar xf - -C "$out/wall_cases")
echo "wall_cases.sh: exit $rc; outputs in $out/wall_cases"
exit "$rc"
