#!/usr/bin/env bash
# Does `rockflow run` of rockprep's permeability scene show its flow? The issue's Berea 100^3
# crop at the rc per voxel in RESOLUTIONS (default "0.5 0.85"), each scene written twice: with
# rockprep's default body force and with --body-force 0.02 (the default before 2026-12-06); each
# run, and the block's flow rate over the flow stage's second half (regions.csv): its mean along
# the flow axis against the standard error of that mean, and the two transverse means.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/flow; mkdir -p $W
for v in ${RESOLUTIONS:-0.5 0.85}; do
  for force in default 0.02; do
    opt=(); [ $force = default ] || opt=(--body-force $force)
    berea_prep 0:100,0:100,0:100 $W/S --seed 7 --rc-per-voxel $v "${opt[@]}" --tile-cache $W/cache
    grep -E "watch it flow|median" $W/S.log | head -3
    $B/rockflow run $W/S/scene.toml --backend cuda --out $W/run > $W/run.txt 2>&1
    echo "$v $force rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//')"
    cp $W/run/regions.csv $O/regions_${v}_$force.csv
    python3 - $W/run/regions.csv $W/S/run.json $v $force <<'PY'
import csv, json, math, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith('#'))
        if r['stage'] == 'flow' and r['type'] == 'fluid']
rows = rows[len(rows) // 2:]
g = json.load(open(sys.argv[2]))['parameters']['body_force']
def stats(a):
    q = [float(r['flow_rate_' + a]) for r in rows]
    m = sum(q) / len(q)
    sd = math.sqrt(sum((x - m) ** 2 for x in q) / (len(q) - 1))
    return m, sd / math.sqrt(len(q))
(mx, ex), (my, ey), (mz, ez) = stats('x'), stats('y'), stats('z')
print(f"{sys.argv[3]} rc per voxel, g = {g} ({sys.argv[4]}): flow rate x {mx:.2f} +- {ex:.2f} "
      f"({mx / ex:.1f} standard errors; {len(rows)} samples), y {my:.2f} +- {ey:.2f}, "
      f"z {mz:.2f} +- {ez:.2f}")
PY
  done
done
