#!/usr/bin/env bash
# A flux without a force? rockprep's permeability scene of the issue's Berea 100^3 crop at each rc
# per voxel in RESOLUTIONS (default "0.5 0.85"), packed with seeds SEEDS (default "7 8") and a flow
# stage of FLOW steps (default 6000), run by rockflow with the fluid's body force g = 0, 0.02 and
# rockprep's default; the block's flow rate along x over the flow stage after its first 2000
# steps (mean, and the standard error of means of 10 consecutive samples), and the fluid's total
# momentum px at the first rows and the last (thermo.csv).
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/zero; mkdir -p $W
for v in ${RESOLUTIONS:-0.5 0.85}; do
  for seed in ${SEEDS:-7 8}; do
    berea_prep 0:100,0:100,0:100 $W/S --seed $seed --rc-per-voxel $v --flow-steps ${FLOW:-6000} \
      --tile-cache $W/cache
    default=$(python3 -c "import json; print(json.load(open('$W/S/run.json'))['parameters']['body_force'])")
    for g in 0 0.02 $default; do
      sed "s/^body_force = \[[^]]*\]/body_force = [$g, 0.0, 0.0]/" $W/S/scene.toml > $W/S/g.toml
      $B/rockflow run $W/S/g.toml --backend cuda --out $W/run > $W/run.txt 2>&1 ||
        { tail -2 $W/run.txt; continue; }
      cp $W/run/regions.csv $O/regions_${v}_s${seed}_g$g.csv
      cp $W/run/thermo.csv $O/thermo_${v}_s${seed}_g$g.csv
      python3 - $W/run/regions.csv $W/run/thermo.csv "$v seed $seed g $g" <<'PY'
import csv, math, sys
def rows(path):
    return list(csv.DictReader(l for l in open(path) if not l.startswith('#')))
flow = [r for r in rows(sys.argv[1]) if r['stage'] == 'flow' and r['type'] == 'fluid']
start = int(flow[0]['step']) + 2000
q = [float(r['flow_rate_x']) for r in flow if int(r['step']) >= start]
b = [sum(q[k:k + 10]) / 10 for k in range(0, len(q) - 9, 10)]
m = sum(b) / len(b)
e = math.sqrt(sum((x - m) ** 2 for x in b) / (len(b) - 1) / len(b))
t = [r for r in rows(sys.argv[2]) if r['stage'] == 'flow']
px = [float(r['px']) for r in t]
print(f"{sys.argv[3]}: block flow rate x {m:.2f} +- {e:.2f} ({len(q)} samples); "
      f"px first {px[0]:.0f} {px[1]:.0f} {px[2]:.0f}, last {px[-1]:.0f}, "
      f"mean after 2000 {sum(px[len(px) // 3:]) / len(px[len(px) // 3:]):.0f}")
PY
    done
  done
done
