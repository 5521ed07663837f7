#!/usr/bin/env bash
# One lean device call for the GPU's buried part by default (bundle .carry/gpu as
# where_users_run.sh makes it; .carry/gpu/COMMIT names its build): the GPU tests, rockprep's
# scenes run by ed1772a (rockflow-old) and by this build in the scenes' double precision and in
# single, and the bench's rock and bulk cases in double and single.
set -uo pipefail
export LD_LIBRARY_PATH=$PWD/.carry/gpu/lib:/tmp/rockprep-libs
mkdir -p .carry/gpu/bin && tar xJf .carry/gpu/bins.tar.xz -C .carry/gpu/bin
mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
B=$PWD/.carry/gpu/bin; W=/tmp/r16; mkdir -p $W
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader; cat .carry/gpu/COMMIT
$B/unit_gpu > $W/unit_gpu.txt 2>&1; echo "unit_gpu rc=$? $(grep -E '^\[  (PASSED|FAILED)' $W/unit_gpu.txt | tr '\n' ' ')"
$B/unit_sim --gtest_filter='*/cuda:*CUDA*:*Cuda*:*Gpu*' > $W/unit_sim.txt 2>&1
echo "unit_sim rc=$? $(grep -E '^\[  (PASSED|FAILED)' $W/unit_sim.txt | tr '\n' ' ')"
grep -E "^\[  FAILED" $W/unit_gpu.txt $W/unit_sim.txt | head
for r in 05 085; do
  extra=(); [ $r = 05 ] && extra=(--rc-per-voxel 0.5)
  [ -f $W/S$r/scene.toml ] || $B/rockprep run .carry/rock/berea_100_to_300.npz --labels true=pore,false=solid \
    --crop 0:100,0:100,0:100 --spacing 5.345,5.345,5.345 --unit um --layout permeability \
    --threads $(nproc) --seed 7 "${extra[@]}" --out $W/S$r > $W/prep$r.log 2>&1 || tail -3 $W/prep$r.log
  sed 's/^seed = 7$/seed = 7\nprecision = "single"/' $W/S$r/scene.toml > $W/S$r/single.toml
done
for r in 05 085; do
  for run in "rockflow-old scene" "rockflow scene" "rockflow-old single" "rockflow single"; do
    set -- $run
    $B/$1 run $W/S$r/$2.toml --backend cuda --out $W/out_$1_$2_$r > $W/run.txt 2>&1
    echo "run S$r $1 $2 rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//')"
    python3 -c "import json;d=json.load(open('$W/out_$1_$2_$r/summary.json'));print('  T',d['final_temperature'],'buried',d.get('buried_particles'),'solid',d['solid']['invariant'])"
  done
done
for p in double single; do
  $B/rockflow bench --backend cuda --case rock --solid $W/S05/solid.h5 --particles 1000000 --steps 300 --precision $p 2>&1 | tail -1
  $B/rockflow bench --backend cuda --case bulk --particles 370043 --steps 1000 --precision $p 2>&1 | tail -1
done
