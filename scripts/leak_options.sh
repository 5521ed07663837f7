#!/usr/bin/env bash
# The options against fluid in the grains, measured side by side on one real crop
# (docs/walls.md, "Fluid inside the grains"): for each, rockprep run packs the crop, rockflow run
# drives the fluid, and the leak invariant (thermo.csv's solid_inside) counts the fluid particles
# inside solid voxels every THERMO steps. The options:
#   walls1       the wall model alone, walls 1 rc thick (the old default), no bounce
#   walls2       the wall model alone, walls 2 rc thick, no bounce
#   filled       the wall model alone, walls 12 rc thick (every solid voxel of a small crop), no bounce
#   bounce       walls 1 rc thick and the solid grid's bounce (the new default)
# Usage: bash scripts/leak_options.sh [--crop Z0:Z1,Y0:Y1,X0:X1] [--steps N] [--backend cpu|cuda]
#          [--tiles DB] [--image NPZ] [--out DIR] [--rockprep BIN] [--rockflow BIN]
# Prints one line per option (particles, wall particles, solid_inside at each check, time) and
# writes DIR/leak_options.csv.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
crop=0:24,0:24,24:48
steps=4000
thermo=500
backend=cpu
threads=2
tiles=""
image=$here/../shared/data/rocks/berea_100_to_300.npz
out=out/leak_options
rockprep=$here/build/bin/rockprep
rockflow=$here/build/bin/rockflow
while [ $# -gt 0 ]; do
  case $1 in
    --crop) crop=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --thermo) thermo=$2; shift 2 ;;
    --backend) backend=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --tiles) tiles=$2; shift 2 ;;
    --image) image=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --rockprep) rockprep=$2; shift 2 ;;
    --rockflow) rockflow=$2; shift 2 ;;
    *) echo "leak_options.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -f "$image" ] || { echo "leak_options.sh: $image: no such file (../shared/data/rocks)" >&2; exit 2; }
mkdir -p "$out"
echo "option,wall_thickness_rc,bounce,particles,wall_particles,steps,inside_at_checks,max_inside,seconds" > "$out/leak_options.csv"
for option in walls1 walls2 filled bounce; do
  case $option in
    walls1) thick=1; bounce=false ;;
    walls2) thick=2; bounce=false ;;
    filled) thick=12; bounce=false ;;  # 24 voxels: every solid voxel of a 24^3 crop
    bounce) thick=1; bounce=true ;;
  esac
  d=$out/$option
  rm -rf "$d"
  "$rockprep" run "$image" --labels true=pore,false=solid --crop "$crop" --spacing 5.345,5.345,5.345 \
    --unit um --rc-per-voxel 0.5 --layout permeability --wall-thickness-rc $thick \
    ${tiles:+--tiles "$tiles"} --body-force 0.04 --relax-steps 100 --flow-steps "$steps" \
    --thermo-every "$thermo" --region-every "$thermo" --quiet --out "$d" > "$d.prep.log" 2>&1
  # Count, do not stop: the leak invariant's limit out of the way, the bounce on or off.
  sed -i "s/^file = \"solid.h5\"$/file = \"solid.h5\"\nbounce = $bounce\nstop_count = 1000000000\nstop_depth = 4/" "$d/scene.toml"
  start=$(date +%s)
  # The watchdog off: its stop at stop_depth would end a leaking run; here the count is the point.
  "$rockflow" run "$d/scene.toml" --out "$d/run" --backend "$backend" --threads "$threads" \
    --watchdog off > "$d/run.log" 2>&1
  seconds=$(( $(date +%s) - start ))
  python3 - "$d" "$option" "$thick" "$bounce" "$steps" "$seconds" >> "$out/leak_options.csv" <<'EOF'
import csv, json, sys
d, option, thick, bounce, steps, seconds = sys.argv[1:]
run = json.load(open(d + "/run.json"))
rows = [r for r in csv.DictReader(l for l in open(d + "/run/thermo.csv") if not l.startswith("#"))]
inside = [int(r["solid_inside"]) for r in rows if r["stage"] == "flow"]
walls = sum(v for k, v in run["particles"]["by_type"].items() if k != "fluid")
print(f'{option},{thick},{bounce},{run["particles"]["total"]},{walls},{steps},'
      f'{" ".join(map(str, inside))},{max(inside)},{seconds}')
EOF
  tail -1 "$out/leak_options.csv"
done
