#!/usr/bin/env bash
# The converged continuum reference on the device (issue 52; docs/lbm.md, "The ladder on the
# GPU"): the lbm GPU tests, then `rockflow lbm --backend cuda` refinement ladders of the real-rock
# masks and of the validation shapes, single and double precision side by side where both run.
# Carries .carry/gpu (build_bundle.sh, binaries packed as bins.tar.xz) and .carry/masks: the
# rock masks are the solid.h5 that `rockprep run IMAGE --layout permeability` writes on the CPU
# machine (crops as named: berea50 = berea_100_to_300.npz 0:50 on each axis, berea100 0:100,
# bereaci 40:56, leopard100 the whole image_Leopard_slice100.npy, leopard50 its 0:50), the shapes
# come from scripts/lbm_shapes.py (spheresL: cell L, radius 0.3103 L; tubeR: radius R).
# ITEMS picks and orders the runs (default: all, most needed first); each run has its own time
# limit. Everything lands in $OUT/lbm.tgz (one lbm.json and log per run) and $OUT/lbm.log.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
M=$PWD/.carry/masks
items=${ITEMS:-tests berea50 berea100 leopard100 bereaci leopard50 spheres32 spheres64 tubes berea100d spheres96}
ladder() {  # NAME MASK LIMIT_S ARGS...: one rockflow lbm run, its result line
  local name=$1 mask=$2 limit=$3
  shift 3
  timeout "$limit" $B/rockflow lbm "$mask" --out "$O/runs/$name" --backend cuda --threads 16 "$@" \
    > "$O/runs/$name.log" 2>&1
  echo "== $name ($* ; exit $?)"
  grep -E "^lbm: refine|^permeability|porosity|warning" "$O/runs/$name.log"
}
mkdir -p "$O/runs"
{
  nvidia-smi --query-gpu=name,memory.total,clocks.max.sm --format=csv,noheader
  echo "commit $(cat .carry/gpu/COMMIT)  date $(date -u +%Y-%m-%dT%H:%MZ)"
  for item in $items; do
    case $item in
      tests)
        $B/unit_gpu --gtest_filter='LbmGpu.*' 2>&1 | grep -E "OK|FAILED|PASSED|SKIP|Failure" ;;
      berea50)
        ladder berea50-double $M/berea50.h5 120 --precision double --refine 1,2,3,4
        ladder berea50-single $M/berea50.h5 120 --precision single --refine 1,2,3,4
        ladder berea50-single-cold $M/berea50.h5 120 --precision single --refine 1,2,3,4 \
          --warm-start off ;;
      berea100) ladder berea100-single $M/berea100.h5 240 --precision single --refine 1,2,3,4 ;;
      berea100d) ladder berea100-double $M/berea100.h5 240 --precision double --refine 1,2,3,4 ;;
      leopard100) ladder leopard100-single $M/leopard100.h5 240 --precision single --refine 1,2,3,4 ;;
      bereaci) ladder bereaci-single $M/bereaci.h5 60 --precision single --refine 1,2,3,4,5,6 ;;
      leopard50) ladder leopard50-single $M/leopard50.h5 90 --precision single --refine 1,2,3,4 ;;
      spheres*) ladder $item-single $M/$item.h5 150 --precision single --tau 1.0 --refine 1,2,3 ;;
      tubes)
        ladder tube8-single $M/tube8.h5 60 --precision single --tau 0.8 --refine 1,2,3,4,5,6
        ladder tube16-single $M/tube16.h5 90 --precision single --tau 0.8 --refine 1,2,3,4 ;;
    esac
  done
} 2>&1 | tee "$O/lbm.log"
tar czf "$O/lbm.tgz" -C "$O" runs lbm.log
