#!/usr/bin/env bash
# How long does rockprep's permeability scene take to reach steady flow under `rockflow run`?
# For each "CROP RC_PER_VOXEL" in CASES (default: the issue's Berea 100^3 crop at 0.5 and at
# rockprep's own 0.85, and the 50^3 crop at 2.0), rockprep writes the scene twice, with the
# default flow stage (2,000 steps) and with LONG steps (default 15,000); rockflow runs both and
# prints its region lines (each region's flow rate and whether it was steady). The long run's
# regions.csv gives the spin-up and the fall: the count and flow rate along x of `block` and `box`
# in windows of 1,000 steps (window_table, bundle_env.sh).
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/settle; mkdir -p $W
LONG=${LONG:-15000}
while read -r crop v; do
  [ -n "$crop" ] || continue
  for steps in 2000 $LONG; do
    berea_prep $crop $W/S --seed 7 --rc-per-voxel $v --flow-steps $steps --tile-cache $W/cache
    [ $steps = 2000 ] && grep -E "median|watch it flow" $W/S.log | head -3
    $B/rockflow run $W/S/scene.toml --backend ${BACKEND:-cuda} --out $W/run > $W/run.txt 2>&1
    echo "== $crop at $v rc per voxel, flow stage $steps steps, rc=$?"
    grep -E "done:|region " $W/run.txt | sed 's/; outputs in.*//'
  done
  tag=${v}_${crop//[:,]/-}
  cp $W/run/regions.csv $O/regions_$tag.csv
  window_table $W/run/regions.csv 1000
done <<< "${CASES:-0:100,0:100,0:100 0.5
0:100,0:100,0:100 0.85
0:50,0:50,0:50 2.0}"
