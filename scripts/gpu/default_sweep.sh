#!/usr/bin/env bash
# The sweep a user runs on the issue's Berea 100^3 crop: the command rockprep suggests at RC rc
# per voxel (default 0.5), with its defaults (the viscosity calibrated, the warm-up by the pore
# rule, the points chained), against k once the flow has settled (scripts/gpu/flow_slabs.sh,
# part c). TOP=N keeps the N largest suggested forces; SWEEP_ARGS adds options (--max-steps).
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/dsweep; mkdir -p $W
RC=${RC:-0.5}
berea_prep 0:100,0:100,0:100 $W/A --seed 7 --rc-per-voxel $RC --tile-cache $W/cache
cmd=$(grep -o "rockflow sweep [^ ]* --out OUT --forces [0-9.,]*" $W/A.log | head -1)
echo "rockprep suggests: $cmd"
forces=${cmd##*--forces }
[ -n "${TOP:-}" ] && forces=$(echo "$forces" | tr , '\n' | sort -g | tail -n "$TOP" | paste -sd,)
echo "forces: $forces ${SWEEP_ARGS:-}"
$B/rockflow sweep $W/A/scene.toml --backend cuda --forces $forces ${SWEEP_ARGS:-} --out $W/s \
  > $W/s.txt 2>&1
echo "== default sweep at $RC rc per voxel rc=$?"; grep -E "k =|warm-up" $W/s.txt | tail -3
cp $W/s/sweep.json $O/default_sweep_$RC.json; cp $W/s/sweep_blocks.csv $O/default_sweep_blocks_$RC.csv
python3 - $W/s/sweep.json <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print("viscosity", d["viscosity"]["value"], "+-", d["viscosity"]["error"], d["viscosity"]["source"])
for p in d["points"]:
    print("point g", p["force_g"], "J", p["flux_J"], "+-", p["flux_J_error"], "steady", p["steady"],
          "after", p["steady_after_steps"], "steps", p["steps"], "drift", p["drift"], "+-", p["drift_error"])
PY
