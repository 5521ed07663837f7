#!/usr/bin/env bash
# Issue 24's acceptance list, side by side in one device call (docs/benchmarks.md, "Issue 24's
# acceptance in one call"):
#   1. rockprep run of the issue's Berea 100^3 crop (0.5 rc per voxel, then rockprep's own
#      resolution), wall clock with an empty tile cache and again with the warm one;
#   2. rockflow run of the 0.5 scene as rockprep wrote it (its fluid-particle-steps/s);
#   3. the bench's rock case (single precision) from the 0.5 and 0.85 scenes' solid.h5 and from
#      rockprep's scene of the Berea 50^3 crop at 2.0 rc per voxel, at about 4.4 M particles,
#      each beside the bulk liquid of its mobile count;
#   4. bulk 20,000; 64 x 20,000 side by side; bulk 16 M; porous 16 M.
# Each comparison ROUNDS times (default 2), alternating. Bundle as for where_users_run.sh
# (scripts/gpu/build_bundle.sh with ROCKPREP=1; the image in .carry/rock, never committed).
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/acc; mkdir -p $W
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $O/gpu.txt
cat .carry/gpu/COMMIT | tee -a $O/gpu.txt
echo "host: $(nproc) cores"
seconds_since() { python3 -c "print(round($(date +%s.%N) - $1, 2))"; }
prep() {  # prep OUT CROP CACHE [rockprep options]: one timed rockprep run
  local out=$1 crop=$2 cache=$3 t
  shift 3
  t=$(date +%s.%N)
  berea_prep $crop $out --seed 7 --tile-cache $cache "$@"
  echo "$(seconds_since $t) s: $(grep summary $out.log | tail -1)"
}
# 1. rockprep: empty cache, warm cache, for the issue's scene and rockprep's own resolution.
for v in 0.5 auto; do
  opt=(); [ $v = auto ] || opt=(--rc-per-voxel $v)
  rm -rf $W/cache$v
  echo "rockprep 100^3 at $v, empty cache: $(prep $W/S$v 0:100,0:100,0:100 $W/cache$v "${opt[@]}")"
  grep -iE "tiles|rc per voxel" $W/S$v.log | head -4
  for i in 1 2; do
    echo "rockprep 100^3 at $v, warm cache $i: $(prep $W/warm 0:100,0:100,0:100 $W/cache$v "${opt[@]}")"
  done
done
echo "rockprep 50^3 at 2.0: $(prep $W/R2.0 0:50,0:50,0:50 $W/cache2.0 --rc-per-voxel 2.0)"
# 2. The issue's scene as rockprep wrote it, run by rockflow (double, the scene's default).
$B/rockflow run $W/S0.5/scene.toml --backend cuda --out $W/run > $W/run.txt 2>&1
echo "run S0.5 rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//')"
python3 -c "import json; s=json.load(open('$W/run/summary.json')); print('run S0.5: T', s['final_temperature'], 'solid', s.get('solid',{}).get('invariant'), 'mobile M steps/s', s['mobile_mps'], 'split', s.get('time_split'))"
cp $W/run/summary.json $O/run_summary_05.json
# 3. and 4., alternating rounds.
for round in $(seq ${ROUNDS:-2}); do
  for s in S0.5 Sauto R2.0; do
    line=$($B/rockflow bench --backend cuda --case rock --solid $W/$s/solid.h5 --particles 4450000 \
      --steps 200 2>&1 | tail -1)
    echo "rock $s r$round: $line"
    m=$(echo "$line" | sed -n 's/.*, \([0-9]*\) mobile.*/\1/p')
    [ -n "$m" ] && $B/rockflow bench --backend cuda --case bulk --particles $m --steps 200 2>&1 |
      tail -1 | sed "s/^/rock $s r$round bulk of the mobile count: /"
  done
  $B/rockflow bench --backend cuda --case bulk --particles 20000 --steps 5000 2>&1 | tail -1 |
    sed "s/^/small r$round: /"
  $B/rockflow bench --backend cuda --case bulk --particles 20000 --steps 2000 --ensemble 64 2>&1 |
    tail -1 | sed "s/^/ensemble r$round: /"
  $B/rockflow bench --backend cuda --case bulk --particles 16000000 --steps 200 2>&1 | tail -1 |
    sed "s/^/bulk16M r$round: /"
  $B/rockflow bench --backend cuda --case porous --particles 16000000 --steps 300 2>&1 | tail -1 |
    sed "s/^/porous16M r$round: /"
done
echo done
