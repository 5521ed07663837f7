#!/usr/bin/env bash
# Why does the permeability scene's flow rate fall over 15,000 steps at 0.5 rc per voxel
# (docs/permeability.md, "The scene's flow over time")? Three tests in one call:
# 1. the scene in .carry/settle/S50 (rockprep's Berea 50^3 crop at 0.5 rc per voxel, made on the
#    development machine by `rockprep run berea_100_to_300.npz --labels true=pore,false=solid
#    --crop 0:50,0:50,0:50 --spacing 5.345,5.345,5.345 --unit um --layout permeability --seed 7
#    --rc-per-voxel 0.5 --flow-steps 15000`, where the CPU runs it too; its tiles.h5 left out):
#    rockflow run on the GPU, 15,000 steps; its
#    regions.csv, thermo.csv and summary.json for the CPU comparison;
# 2. the issue's 100^3 crop at 0.5: a sweep at two forces side by side, blocks of 1,000 steps
#    from a 1,000-step warm-up: does the fall scale with the force?
# 3. the same after 50 time units without force (--relax-steps 25000 at dt 0.002, which the sweep
#    runs without its force): does the flow start at the fallen rate?
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/decline; mkdir -p $W
S50=$PWD/.carry/settle/S50
$B/rockflow run $S50/scene.toml --backend cuda --out $W/s50 > $W/s50.txt 2>&1
echo "== 1. S50 on the GPU rc=$?"; grep -E "done:|region " $W/s50.txt | sed 's/; outputs in.*//'
for f in regions.csv thermo.csv summary.json; do cp $W/s50/$f $O/s50_gpu_$f; done
SW=(--backend cuda --viscosity 6.111 --viscosity-error 0.041 --forces 0.0735,0.147 --side-by-side
    --warmup 1000 --block-steps 1000 --window 3 --measure-blocks 12 --max-steps 20000)
for relax in 100 25000; do
  berea_prep 0:100,0:100,0:100 $W/P$relax --seed 7 --rc-per-voxel 0.5 --relax-steps $relax \
    --tile-cache $W/cache
  $B/rockflow sweep $W/P$relax/scene.toml "${SW[@]}" --out $W/sw$relax > $W/sw$relax.txt 2>&1
  echo "== sweep after relax $relax steps rc=$?"; grep -E "k =|steady|mD|warm-up" $W/sw$relax.txt | head -8
  cp $W/sw$relax/sweep_blocks.csv $O/sweep_blocks_relax$relax.csv
  python3 - $W/sw$relax/sweep_blocks.csv <<'PY'
import csv, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith('#'))]
keys = list(rows[0].keys())
print("  columns:", keys)
pts = {}
for r in rows:
    pts.setdefault(r[keys[0]], []).append(float(r[keys[-1]]))
for p, v in pts.items():
    print(f"  point {p}: block flux", " ".join(f"{x:.4g}" for x in v))
PY
done
