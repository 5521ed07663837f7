#!/usr/bin/env bash
# Sample 01: a synthetic three-phase shale stack (pores, organic matter, inorganic matrix) ->
# `rockprep run` (segmentation, pore clusters joining inlet and outlet, surface walls packed from
# the tile database, fluid, reservoirs, slabs, scene) -> `rockflow run` (the 2020 paper's flooding
# set-up: working fluid pushed into a block saturated with source fluid). See README.md here.
#
#   bash samples/01_shale_flooding/run.sh [--out DIR] [--size small|full]
#                                          [--rockprep PATH] [--rockflow PATH] [--threads N]
#
# small (CI, about 10 s on two cores): a 20 x 24 x 32 voxel stack (10 x 12 x 16 rc),
# 300 flooding steps. full: 40 x 48 x 64 voxels, 5,000 flooding steps.
# Checks at the end (exit code 1 when one fails): the packed set has walls of both solid phases
# and no fluid in the deep solid (rockprep's own count check), no working fluid entered the
# block before the virtual wall went away, and some did after it (recovery > 0).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="out/01_shale_flooding"
size="small"
rockprep="$root/build/bin/rockprep"
rockflow="$root/build/bin/rockflow"
threads=0
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --rockprep) rockprep="$2"; shift 2 ;;
    --rockflow) rockflow="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
case "$size" in
  small) shape="20,24,32"; settle=100; flood=300; tile_box=5; tile_eq=1500; variants=1000 ;;
  full) shape="40,48,64"; settle=400; flood=5000; tile_box=6; tile_eq=2000; variants=1024 ;;
  *) echo "run.sh: --size small or full" >&2; exit 2 ;;
esac
rm -rf "$out"
mkdir -p "$out"

# 1. The stack: 1 nm voxels; porosity 0.35 so that the pores percolate along x at this size.
"$rockprep" synth --shape "$shape" --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5 \
  --blob 6 --pore-radius 3 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out "$out/stack"

# 2. Stack -> particles + scene: 3-class multi-Otsu, 0.5 rc per voxel (2 nm per rc), flow along x.
"$rockprep" run "$out/stack/grey" --otsu 3 --rc-per-voxel 0.5 --flow-axis x \
  --tile-box-edge "$tile_box" --tile-equilibrate-steps "$tile_eq" --tile-variants "$variants" \
  --threads "$threads" \
  --settle-steps "$settle" --flood-steps "$flood" --seed 7 --out "$out/setup"

# 3. Flood.
"$rockflow" run "$out/setup/scene.toml" --out "$out/flood" --threads "$threads"

# 4. Checks on the outputs.
sat="$out/flood/saturation.csv"
regions="$out/flood/regions.csv"
flood_from=$((100 + settle))
awk -F, -v from="$flood_from" '
  /^#/ || /^step/ { next }
  $4 == "block" && $5 == "working" && $1 + 0 <= from && $6 + 0 > 0 { early = 1 }
  $4 == "block" && $5 == "working" { last = $6 + 0 }
  END {
    if (early) { print "check failed: working fluid in the block before step " from; exit 1 }
    if (last <= 0) { print "check failed: no working fluid entered the block"; exit 1 }
    print "check: no working fluid in the block before step " from "; " last " particles of it at the end"
  }' "$regions"
awk -F, '
  /^#/ || /^step/ { next }
  { recovery = $6 + 0 }
  END {
    if (!(recovery > 0)) { print "check failed: recovery " recovery; exit 1 }
    print "check: recovery of the source fluid at the end " recovery
  }' "$sat"
# 5. The recovery curve as a picture (Debian's python3-matplotlib, installed by scripts/setup.sh).
if /usr/bin/python3 -c 'import matplotlib' 2>/dev/null; then
  /usr/bin/python3 - "$sat" "$out/flood/recovery.png" <<'PY'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#"))]
rows = [r for r in rows if r["region"] == "block"]
t = [float(r["time"]) for r in rows]
rec = [float(r["recovery"]) for r in rows]
fig, ax = plt.subplots(figsize=(5, 3.5), dpi=120)
ax.plot(t, rec, "-o", ms=3)
ax.set_xlabel("time (tau)")
ax.set_ylabel("recovery = 1 - source saturation")
ax.set_title("sample 01: source fluid recovered from the block")
fig.tight_layout()
fig.savefig(sys.argv[2] + ".tmp.png")
import os
os.replace(sys.argv[2] + ".tmp.png", sys.argv[2])
PY
  echo "sample 01: recovery curve in $out/flood/recovery.png"
else
  echo "sample 01: no matplotlib here: the recovery curve is in $sat (column recovery)"
fi
for phase in organic_wall inorganic_wall; do
  grep -q "\"$phase\"" "$out/setup/run.json" || { echo "check failed: no $phase particles"; exit 1; }
done
echo "sample 01: done; outputs in $out (setup/particles.xmf and flood/final.xmf open in ParaView)"
