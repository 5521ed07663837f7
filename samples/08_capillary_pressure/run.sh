#!/usr/bin/env bash
# Sample 08: the primary-drainage capillary pressure curve Pc(S_w) of a synthetic shale. A stack
# like sample 01's with larger pores -> `rockprep run --layout flooding` (the block between an inlet reservoir
# pushed by a slab and an outlet reservoir held by a back-pressure slab) with the walls' affinity
# of the contact-angle calibration (A_SW = -18) -> `rockflow pc`: the source fluid becomes the
# wetting liquid W, the working fluid a non-wetting liquid N (A_WN = -30, A_SN = -8: 42 degrees
# through W), and N is pushed in at rising capillary pressure, each level run to a steady
# saturation, then (above the tiny size) W is let back in at falling pressure. README.md here.
#
#   bash samples/08_capillary_pressure/run.sh [--size tiny|small|full] [--backend cpu|cuda]
#        [--out DIR] [--rockprep PATH] [--rockflow PATH] [--threads N]
#        [--nonwetting-wall-A A] [--prep-only | --flow-only]
#
# tiny (CI, under a minute on two cores with sample 01's tiles cached): a 20 x 24 x 32 voxel stack,
# three levels of short blocks: the chain end to end, not a converged curve.
# small: the same stack, six drainage levels and three imbibition levels (CPU: about an hour).
# full: 40 x 48 x 64 voxels, finer levels, longer blocks: for the GPU.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="out/08_capillary_pressure"
size="small"
backend="cpu"
rockprep="$root/build/bin/rockprep"
rockflow="$root/build/bin/rockflow"
threads=0
prep=1
flow=1
asn=-8
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size="$2"; shift 2 ;;
    --backend) backend="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --rockprep) rockprep="$2"; shift 2 ;;
    --rockflow) rockflow="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --nonwetting-wall-A) asn="$2"; shift 2 ;;
    --prep-only) flow=0; shift ;;
    --flow-only) prep=0; shift ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [ "$prep" -eq 0 ] && [ "$flow" -eq 0 ]; then
  echo "run.sh: --prep-only and --flow-only exclude each other" >&2; exit 2
fi
# Tile settings as sample 01's (a shared cache: the second sample builds no tiles). Pores of 7
# voxels in radius (sample 01's 3 leave throats of 1 rc at 0.5 rc per voxel, where N does not enter
# at Pc = 40): pore bodies of about 3 rc in radius enter near 2 gamma cos(theta) / r = 5 at 42
# degrees, the 2.2 rc critical throat near 13; the levels reach 30.
case "$size" in
  tiny)
    shape="20,24,32"; tile_box=5; tile_eq=1500; variants=1000
    pressures="0,15,30"; imbibition=""
    steps=(--ramp-steps 200 --block-steps 100 --sample-every 20 --window 1 --measure-blocks 3
      --max-level-steps 1200) ;;
  small)
    shape="20,24,32"; tile_box=5; tile_eq=1500; variants=1000
    pressures="0,5,10,15,20,30"; imbibition="15,5,0"
    steps=(--ramp-steps 1000 --block-steps 1000 --window 2 --measure-blocks 4
      --max-level-steps 20000) ;;
  full)
    shape="40,48,64"; tile_box=6; tile_eq=2000; variants=1024
    pressures="0,2.5,5,7.5,10,12.5,15,20,25,30"; imbibition="25,20,15,10,5,0"
    steps=(--ramp-steps 3000 --block-steps 2000 --window 4 --measure-blocks 5
      --max-level-steps 60000) ;;
  *) echo "run.sh: --size tiny, small or full" >&2; exit 2 ;;
esac

if [ "$prep" -eq 1 ]; then
  rm -rf "$out"
  mkdir -p "$out"
  # 1. The stack: sample 01's settings (1 nm voxels, porosity 0.35) with pores of radius 7.
  "$rockprep" synth --shape "$shape" --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5 \
    --blob 6 --pore-radius 7 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out "$out/stack"
  # 2. The flooding set-up: 0.5 rc per voxel, flow along x, both walls at A = -18 (the wall
  #    affinity at which the W-N contact angle is calibrated), reservoirs long enough to drain
  #    the block's pores.
  "$rockprep" run "$out/stack/grey" --otsu 3 --rc-per-voxel 0.5 --flow-axis x \
    --a-organic -18 --a-inorganic -18 --inlet-rc 8 \
    --tile-box-edge "$tile_box" --tile-equilibrate-steps "$tile_eq" --tile-variants "$variants" \
    --threads "$threads" --seed 7 --out "$out/setup"
fi
if [ "$flow" -eq 0 ]; then
  echo "sample 08: prepared $out/setup; drain it with: bash $0 --size $size --out $out" \
    "--flow-only [--backend cuda] [--rockflow PATH]"
  exit 0
fi
[ -s "$out/setup/scene.toml" ] || { echo "run.sh: no $out/setup/scene.toml (run without" \
  "--flow-only first)" >&2; exit 2; }

# 3. Primary drainage (and imbibition above the tiny size).
imb=()
[ -n "$imbibition" ] && imb=(--imbibition "$imbibition")
rm -rf "$out/pc"
"$rockflow" pc "$out/setup/scene.toml" --out "$out/pc" --pressures "$pressures" \
  ${imb[@]+"${imb[@]}"} --nonwetting-wall-A "$asn" "${steps[@]}" --backend "$backend" \
  --threads "$threads" | tee "$out/pc.log"

# 4. Checks: every output is there, and N entered the block at the highest pressure (S_w fell
#    below its value at Pc = 0).
for f in pc.csv pc_blocks.csv pc.json pc.png states/level_0.h5; do
  [ -s "$out/pc/$f" ] || { echo "sample 08: $out/pc/$f is missing" >&2; exit 1; }
done
awk -F, '
  /^#/ || /^level/ { next }
  $2 == "drainage" { if (first == "") first = $5 + 0; last = $5 + 0 }
  END {
    if (!(last < first)) { print "check failed: S_w did not fall (" first " -> " last ")"; exit 1 }
    print "check: S_w in the block " first " at the first level, " last " at the highest"
  }' "$out/pc/pc.csv"
echo "sample 08: outputs in $out: setup/ (rockprep), pc/pc.csv (a row per level), pc/pc.json"
echo "           (S_w and the measured Pc with errors, provenance), pc/pc.png (the curve),"
echo "           pc/states/level_*.h5 + .xmf (where the phases are at each level; ParaView)"
