#!/usr/bin/env bash
# Sample 06: the permeability of a synthetic shale. `rockprep synth` makes a three-phase stack,
# `rockprep run --layout permeability` turns it into a periodic sample (the block and its mirror
# image along x, surface walls from the tile database, one fluid driven by a body force), and
# `rockflow sweep` drives it at four forces: flow rate vs gradient, Darcy and Forchheimer fits,
# k in rc^2, nm^2 and millidarcy. README.md here says what comes out.
#
#   bash samples/06_shale_permeability/run.sh [--size tiny|small|full] [--backend cpu|cuda]
#        [--out DIR] [--rockprep PATH] [--rockflow PATH] [--threads N] [--prep-only | --sweep-only]
#
# tiny (CI, about a minute on two cores): 12 x 16 x 24 voxels, short blocks, the tiny viscosity
# calibration: the chain end to end, not a converged k (its flux is mostly thermal noise).
# small: 24 x 24 x 48 voxels, CPU minutes. full: 56 x 56 x 112 voxels (about 0.6 M particles),
# long blocks: for the GPU (--backend cuda; a few minutes on an H200).
# --prep-only stops after rockprep (DIR/setup is all the sweep needs: carry DIR to a machine
# without rockprep); --sweep-only runs only the sweep of an earlier DIR/setup.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="out/06_shale_permeability"
size="small"
backend="cpu"
rockprep="$root/build/bin/rockprep"
rockflow="$root/build/bin/rockflow"
threads=0
prep=1
sweep=1
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size="$2"; shift 2 ;;
    --backend) backend="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --rockprep) rockprep="$2"; shift 2 ;;
    --rockflow) rockflow="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --prep-only) sweep=0; shift ;;
    --sweep-only) prep=0; shift ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [ "$prep" -eq 0 ] && [ "$sweep" -eq 0 ]; then
  echo "run.sh: --prep-only and --sweep-only exclude each other" >&2; exit 2
fi
# Stack (Z,Y,X voxels of 1 nm; 0.5 rc per voxel), tile sets, and the sweep's blocks. The pores
# are about 1.5 rc in radius: the peak shear rate n g R / (2 mu) stays below 0.25 and the
# Reynolds number far below 1 at these forces.
case "$size" in
  tiny)
    shape="12,16,24"; tiles=(--tile-box-edge 4 --tile-relax-steps 100
      --tile-equilibrate-steps 1000 --tile-variants 500)
    forces="0.05,0.1,0.15,0.2"
    steps=(--warmup 200 --block-steps 100 --window 2 --measure-blocks 3 --max-steps 1500
      --calibration tiny) ;;
  small)
    shape="24,24,48"; tiles=(--tile-box-edge 5 --tile-equilibrate-steps 1500 --tile-variants 1000)
    forces="0.02,0.04,0.06,0.08"
    steps=(--warmup 1000 --block-steps 500 --window 2 --measure-blocks 6 --max-steps 8000
      --calibration small) ;;
  full)
    shape="56,56,112"; tiles=()
    forces="0.02,0.04,0.06,0.08"
    steps=(--warmup 4000 --block-steps 2000 --window 3 --measure-blocks 10 --max-steps 50000
      --calibration full) ;;
  *) echo "run.sh: --size tiny, small or full" >&2; exit 2 ;;
esac

if [ "$prep" -eq 1 ]; then
  rm -rf "$out"
  mkdir -p "$out"
  # 1. The stack: porosity 0.35 so that the pores percolate along x (sample 01's settings).
  "$rockprep" synth --shape "$shape" --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5 \
    --blob 6 --pore-radius 3 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out "$out/stack"
  # 2. Stack -> periodic sample: 3-class multi-Otsu, 0.5 rc per voxel (2 nm per rc), flow along x,
  #    the block mirrored along x, only the pores that join the block's x faces.
  "$rockprep" run "$out/stack/grey" --otsu 3 --rc-per-voxel 0.5 --layout permeability \
    --flow-axis x ${tiles[@]+"${tiles[@]}"} --threads "$threads" --seed 7 --out "$out/setup"
fi
if [ "$sweep" -eq 0 ]; then
  echo "sample 06: prepared $out/setup; sweep it with: bash $0 --size $size --out $out" \
    "--sweep-only [--backend cuda] [--rockflow PATH]"
  exit 0
fi
[ -s "$out/setup/scene.toml" ] || { echo "run.sh: no $out/setup/scene.toml (run without" \
  "--sweep-only first)" >&2; exit 2; }

# 3. The sweep; the viscosity calibration is cached next to the outputs.
rm -rf "$out/sweep"
"$rockflow" sweep "$out/setup/scene.toml" --out "$out/sweep" --forces "$forces" "${steps[@]}" \
  --viscosity-cache "$out/viscosity-cache" --backend "$backend" --threads "$threads" |
  tee "$out/sweep.log"

# 4. Checks: every output is there, and the Darcy fit gives a permeability (positive, except at
#    the tiny size, whose flux is mostly noise).
for f in sweep.csv sweep_blocks.csv sweep.json sweep.png; do
  [ -s "$out/sweep/$f" ] || { echo "sample 06: $out/sweep/$f is missing" >&2; exit 1; }
done
awk -v tiny=$([ "$size" = tiny ] && echo 1 || echo 0) '
  /^permeability \(Darcy fit\): / { k = $4; found = 1 }
  END {
    if (!found) { print "check failed: no Darcy fit in the sweep output"; exit 1 }
    if (!tiny && !(k + 0 > 0)) { print "check failed: Darcy permeability " k " rc^2"; exit 1 }
    print "check: Darcy permeability " k " rc^2" (tiny ? " (tiny: not converged)" : " > 0")
  }' "$out/sweep.log"
echo "sample 06: outputs in $out: setup/ (particles, scene), sweep/sweep.csv (one row per force),"
echo "           sweep/sweep.json (fits, units), sweep/sweep.png (flow rate vs gradient)"
