#!/usr/bin/env bash
# The sweep a user runs on the issue's Berea 100^3 crop at 0.5 rc per voxel: the command rockprep
# suggests, its defaults (the viscosity calibrated, the warm-up by the pore rule, the points
# chained), against k once the flow has settled (scripts/gpu/flow_slabs.sh, part c).
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/dsweep; mkdir -p $W
berea_prep 0:100,0:100,0:100 $W/A --seed 7 --rc-per-voxel 0.5 --tile-cache $W/cache
cmd=$(grep -o "rockflow sweep [^ ]* --out OUT --forces [0-9.,]*" $W/A.log | head -1)
echo "rockprep suggests: $cmd"
forces=${cmd##*--forces }
$B/rockflow sweep $W/A/scene.toml --backend cuda --forces $forces --out $W/s > $W/s.txt 2>&1
echo "== default sweep rc=$?"; grep -vE "^\s*$|\r" $W/s.txt | grep -vE "block [0-9]+," | tail -12
cp $W/s/sweep.json $O/default_sweep.json; cp $W/s/sweep_blocks.csv $O/default_sweep_blocks.csv
