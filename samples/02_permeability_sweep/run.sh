#!/usr/bin/env bash
# Sample 02: a permeability sweep of a slit pore (scene.toml). Four driving forces, each run to a
# steady state; flow rate vs gradient with error bars, Darcy and Forchheimer fits, permeability
# in rc^2, nm^2 and millidarcy. README.md says what comes out and how to read it.
#
#   bash samples/02_permeability_sweep/run.sh                 # about 15 min on two CPU cores
#   bash samples/02_permeability_sweep/run.sh --backend cuda  # the same on the GPU
#   bash samples/02_permeability_sweep/run.sh --tiny          # seconds (CI): 2 forces, short blocks
#
# Options: --rockflow PATH (default build/bin/rockflow), --out DIR (default
# out/02_permeability_sweep); anything else goes to `rockflow sweep` (e.g. --backend cuda).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
rockflow="$here/../../build/bin/rockflow"
out="out/02_permeability_sweep"
tiny=0
extra=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --tiny) tiny=1 ;;
    --rockflow) rockflow="$2"; shift ;;
    --out) out="$2"; shift ;;
    *) extra+=("$1") ;;
  esac
  shift
done
if [[ $tiny -eq 1 ]]; then
  # Two forces, blocks of 100 steps, the tiny viscosity calibration cached next to the outputs:
  # checks that the pipeline runs end to end, not the physics (the validation cases do that).
  "$rockflow" sweep "$here/scene.toml" --out "$out" --forces 0.02,0.04 --warmup 200 \
    --block-steps 100 --window 2 --measure-blocks 3 --max-steps 1500 --calibration tiny \
    --viscosity-cache "$out/viscosity-cache" ${extra[@]+"${extra[@]}"}
  for f in sweep.csv sweep_blocks.csv sweep.json sweep.png; do
    [[ -s "$out/$f" ]] || { echo "sample 02: $out/$f is missing" >&2; exit 1; }
  done
else
  # Peak shear rate at the walls n g h / (2 mu) = 0.16 at the largest force: Newtonian.
  "$rockflow" sweep "$here/scene.toml" --out "$out" --forces 0.01,0.02,0.03,0.04 \
    --calibration small ${extra[@]+"${extra[@]}"}
fi
echo "sample 02: outputs in $out: sweep.csv (one row per force), sweep.json (fits, units),"
echo "           sweep.png (flow rate vs gradient), sweep_blocks.csv (flux per block)"
