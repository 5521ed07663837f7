#!/usr/bin/env bash
# Sample 07: relative permeability curves of a synthetic shale. Sample 06 makes the periodic
# sample (`rockprep synth`, `rockprep run --layout permeability`) and measures its absolute
# permeability (`rockflow sweep`; not at the tiny size); `rockflow relperm` then floods it with two
# immiscible liquids at several wetting saturations, the non-wetting one placed in the largest
# pores (drainage), both driven by the same body force: kr_W and kr_N against S_w. README.md here
# says what comes out.
#
#   bash samples/07_relative_permeability/run.sh [--size tiny|small|full] [--backend cpu|cuda]
#        [--out DIR] [--rockprep PATH] [--rockflow PATH] [--threads N]
#        [--nonwetting-wall-A A] [--prep-only | --flow-only]
#
# tiny (CI, under a minute on two cores with sample 06's tiles cached): 12 x 16 x 24 voxels, two
# saturations, short blocks, no sweep: the chain end to end, not converged curves.
# small: 24 x 24 x 48 voxels, three saturations, CPU tens of minutes or a minute on a GPU.
# full: 56 x 56 x 112 voxels (about 0.6 M particles), five saturations side by side: for the GPU.
# --nonwetting-wall-A: the non-wetting liquid's wall affinity (default: the fluid's, -18, neutral
# wetting at 90 degrees; docs/calibration/contact_angle_WN_A_SN.csv gives the angle of others).
# --prep-only stops after rockprep (DIR/setup is all the flow needs: carry DIR to a machine
# without rockprep); --flow-only runs the sweep and relperm on an earlier DIR/setup.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="out/07_relative_permeability"
size="small"
backend="cpu"
rockprep="$root/build/bin/rockprep"
rockflow="$root/build/bin/rockflow"
threads=0
prep=1
flow=1
wet=()
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size="$2"; shift 2 ;;
    --backend) backend="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --rockprep) rockprep="$2"; shift 2 ;;
    --rockflow) rockflow="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --nonwetting-wall-A) wet=(--nonwetting-wall-A "$2"); shift 2 ;;
    --prep-only) flow=0; shift ;;
    --flow-only) prep=0; shift ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [ "$prep" -eq 0 ] && [ "$flow" -eq 0 ]; then
  echo "run.sh: --prep-only and --flow-only exclude each other" >&2; exit 2
fi
# The relperm runs' blocks (as sample 06's sweep) and force: the sweep's middle one, low enough
# for the capillary forces to hold the phases where they sit (capillary number below 0.01).
case "$size" in
  tiny)
    # g = 0.5: at 0.1 the single-phase flux (about 0.005) was below its noise (+-0.012), and its
    # sign, which relperm checks, came from the noise.
    force=0.5; saturations="0.3,0.6"
    steps=(--warmup 200 --block-steps 200 --window 2 --measure-blocks 4 --max-steps 2400) ;;
  small)
    force=0.05; saturations="0.25,0.5,0.75"
    steps=(--warmup 1000 --block-steps 500 --window 2 --measure-blocks 6 --max-steps 12000) ;;
  full)
    force=0.05; saturations="0.2,0.35,0.5,0.65,0.8"
    steps=(--warmup 4000 --block-steps 2000 --window 3 --measure-blocks 10 --max-steps 50000) ;;
  *) echo "run.sh: --size tiny, small or full" >&2; exit 2 ;;
esac

# 1-3. Sample 06: the stack, the periodic sample and (above tiny) its single-phase sweep, whose
#      sweep.json gives k_abs and the viscosity. The tiny sweep is noise; relperm's kr needs only
#      its own single-phase run at the same force.
six=(--size "$size" --out "$out" --rockprep "$rockprep" --rockflow "$rockflow" --threads "$threads"
  --backend "$backend")
if [ "$prep" -eq 1 ] && { [ "$flow" -eq 0 ] || [ "$size" = tiny ]; }; then
  bash "$root/samples/06_shale_permeability/run.sh" "${six[@]}" --prep-only
elif [ "$prep" -eq 1 ]; then
  bash "$root/samples/06_shale_permeability/run.sh" "${six[@]}"
elif [ "$size" != tiny ]; then
  bash "$root/samples/06_shale_permeability/run.sh" "${six[@]}" --sweep-only
fi
if [ "$flow" -eq 0 ]; then
  echo "sample 07: prepared $out/setup; flood it with: bash $0 --size $size --out $out" \
    "--flow-only [--backend cuda] [--rockflow PATH]"
  exit 0
fi
sweep=()
[ "$size" != tiny ] && sweep=(--sweep "$out/sweep/sweep.json")

# 4. Two liquids at each saturation, side by side, against the single-phase run at the same force.
rm -rf "$out/relperm"
"$rockflow" relperm "$out/setup/scene.toml" --out "$out/relperm" --saturations "$saturations" \
  --force "$force" --placement drainage ${wet[@]+"${wet[@]}"} ${sweep[@]+"${sweep[@]}"} \
  "${steps[@]}" --side-by-side --backend "$backend" --threads "$threads" | tee "$out/relperm.log"

# 5. Checks: every output is there, and a curve came out (at the tiny size only that: its fluxes
#    are mostly noise); above it, kr_W + kr_N < 1 and the curves monotonic within errors.
for f in relperm.csv relperm_blocks.csv relperm.json relperm.png states/S_1.h5; do
  [ -s "$out/relperm/$f" ] || { echo "sample 07: $out/relperm/$f is missing" >&2; exit 1; }
done
grep -q '^checks: ' "$out/relperm.log" || { echo "sample 07: no checks line" >&2; exit 1; }
if [ "$size" != tiny ]; then
  grep -q '^checks: kr_W + kr_N < 1: yes; kr_W rises and kr_N falls with S_w (2 sigma): yes' \
    "$out/relperm.log" || echo "sample 07: warning: a check of the curves failed (see above)" >&2
fi
echo "sample 07: outputs in $out: setup/ and sweep/ (sample 06's), relperm/relperm.csv (a row per"
echo "           saturation), relperm/relperm.json (kr with errors, checks, units), relperm.png,"
echo "           relperm/states/S_*.h5 + .xmf (where the phases are at the end; ParaView)"
