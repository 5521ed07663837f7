#!/usr/bin/env bash
# Where users run (docs/benchmarks.md, "The issue's Berea crop where users run"): the GPU tests,
# then the issue's Berea scenes (100^3 crop at 0.5 and at rockprep's own 0.85 rc per voxel) run
# by `rockflow run` and by a short `rockflow sweep` (a check that two builds compute the same
# thing: too short for the flow to settle, so its k reads high; docs/permeability.md, "The flow
# rate's slow fall"), with a reference binary (rockflow-old) and
# the new one alternating; the new summaries' time split (stepping against each output); the
# GPU's buried part on and off in the bench's rock case; and the scenes in single precision (their
# default is double) beside the bench's rock and bulk cases in both precisions.
# Bundle (.carry/gpu/bins.tar.xz): rockflow, rockflow-old, rockprep, unit_gpu, unit_sim, stripped;
# .carry/gpu/lib and rockprep-libs.tar.xz as scripts/gpu/build_bundle.sh (ROCKPREP=1) makes
# them; the image in .carry/rock (never committed). TESTS=0 skips the tests, RUNS=0 the runs and
# sweeps, BURIED=0 the buried part's benches, PRECISION=0 the precision comparison; ROUNDS=1 runs
# each comparison once instead of twice; RESOLUTION=0 skips the resolution series. Without
# rockflow-old in the bundle the runs and sweeps use the new binary alone.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/r16; mkdir -p $W
bins="rockflow-old rockflow"; [ -x $B/rockflow-old ] || bins=rockflow
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $O/gpu.txt
cat .carry/gpu/COMMIT | tee -a $O/gpu.txt
if [ "${TESTS:-1}" = 1 ]; then
  $B/unit_gpu > $W/unit_gpu.txt 2>&1; echo "unit_gpu rc=$? $(grep -E '^\[  (PASSED|FAILED)' $W/unit_gpu.txt | tr '\n' ' ')"
  $B/unit_sim --gtest_filter='*/cuda:*CUDA*:*Cuda*:*Gpu*' \
    > $W/unit_sim.txt 2>&1
  echo "unit_sim rc=$? $(grep -E '^\[  (PASSED|FAILED)' $W/unit_sim.txt | tr '\n' ' ')"
  grep -E "^\[  FAILED" $W/unit_gpu.txt $W/unit_sim.txt | head
fi
# The issue's 100^3 scenes, for the sections that use them.
[ "${BURIED:-1}${RUNS:-1}${PRECISION:-1}" = 000 ] ||
for r in 05 085; do
  extra=(); [ $r = 05 ] && extra=(--rc-per-voxel 0.5)
  $B/rockprep run .carry/rock/berea_100_to_300.npz --labels true=pore,false=solid \
    --crop 0:100,0:100,0:100 --spacing 5.345,5.345,5.345 --unit um --layout permeability \
    --threads $(nproc) --seed 7 "${extra[@]}" --out $W/S$r > $W/prep$r.log 2>&1 || tail -3 $W/prep$r.log
  grep summary $W/prep$r.log
done
# The buried part on the GPU (StepView::buried_part, the default): the bench's rock case
# from each scene's solid.h5, on and off alternating, and the bulk liquid of the mobile count.
if [ "${BURIED:-1}" = 1 ]; then
for round in $(seq ${ROUNDS:-2}); do
  for b in on off; do
    $B/rockflow bench --backend cuda --case rock --solid $W/S085/solid.h5 --particles 4450000 \
      --steps 200 --buried-part $b 2>&1 | tail -1 | sed "s/^/buried $b S085 r$round: /"
    $B/rockflow bench --backend cuda --case rock --solid $W/S05/solid.h5 --particles 1000000 \
      --steps 300 --buried-part $b 2>&1 | tail -1 | sed "s/^/buried $b S05 r$round: /"
  done
done
$B/rockflow bench --backend cuda --case bulk --particles 1594498 --steps 200 2>&1 | tail -1
fi
if [ "${RUNS:-1}" = 1 ]; then
for round in $(seq ${ROUNDS:-2}); do
  for r in 05 085; do
    for bin in $bins; do
      $B/$bin run $W/S$r/scene.toml --backend cuda --out $W/run_${bin}_$r > $W/run.txt 2>&1
      echo "run S$r $bin r$round rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//'); T $(python3 -c "import json; print(json.load(open('$W/run_${bin}_$r/summary.json'))['final_temperature'])")"
    done
  done
  for bin in $bins; do
    t=$(date +%s.%N)
    $B/$bin sweep $W/S05/scene.toml --backend cuda --out $W/sweep_$bin --forces 0.02 \
      --viscosity 6.111 --viscosity-error 0.041 --warmup 1000 --block-steps 500 --window 2 \
      --measure-blocks 2 --max-steps 4000 > $W/sweep.txt 2>&1
    echo "sweep S05 $bin r$round rc=$? $(python3 -c "print(round($(date +%s.%N) - $t, 2))") s: $(grep -iE 'MPS' $W/sweep.txt | tail -1)"
  done
done
for r in 05 085; do cp $W/run_rockflow_$r/summary.json $O/summary_new_$r.json; done
cp $W/run_rockflow_085/thermo.csv $O/thermo_new_085.csv
python3 - <<'PY'
import json
for r in ('05','085'):
    n=json.load(open(f'/tmp/r16/run_rockflow_{r}/summary.json'))
    try: o=json.load(open(f'/tmp/r16/run_rockflow-old_{r}/summary.json'))
    except OSError: o={}
    print(r, 'time_split', n.get('time_split'))
    print(r, 'T old/new', o.get('final_temperature'), n['final_temperature'], 'buried new', n.get('buried_particles'), 'solid', o.get('solid',{}).get('invariant'), n.get('solid',{}).get('invariant'))
PY
fi
# What a scene's double precision costs: the scenes run in single by both binaries, and the bench's
# rock and bulk cases (the rock's mobile count) in double and single.
if [ "${PRECISION:-1}" = 1 ]; then
for r in 05 085; do
  sed 's/^seed = 7$/seed = 7\nprecision = "single"/' $W/S$r/scene.toml > $W/S$r/single.toml
  for bin in $bins; do
    $B/$bin run $W/S$r/single.toml --backend cuda --out $W/single_${bin}_$r > $W/run.txt 2>&1
    echo "single run S$r $bin rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//')"
  done
done
for p in double single; do
  $B/rockflow bench --backend cuda --case rock --solid $W/S05/solid.h5 --particles 1000000 \
    --steps 300 --precision $p 2>&1 | tail -1
  $B/rockflow bench --backend cuda --case bulk --particles 370043 --steps 1000 --precision $p 2>&1 | tail -1
done
fi
# What the resolution does to the fluid's share (docs/benchmarks.md, "The rock target and the
# resolution"): rockprep's scene of the Berea 50^3 crop at each rc per voxel in RESOLUTIONS (it
# picks 0.85 for the 100^3 crop), the bench's rock case from each solid.h5 at about RES_PARTICLES
# particles (mirror copies or a sub-cube of the image) by each binary in RES_BINS, alternating,
# beside the bulk liquid of its mobile count, ROUNDS times. RES_BINS may name timing-bound builds
# (build_bundle.sh VARIANTS="bsums:-DMESOROCK_BOUND_NO_FROZEN_SUMS ...": wrong physics on purpose,
# sim/cuda/engine_cuda.cu). RES_SWITCHES runs each binary once per set of bench switches, the sets
# separated by ";" (RES_SWITCHES="--penetration-mask on;--penetration-mask off"; a binary
# without a set's first switch skips that set). RES_PROFILE=1
# adds rockflow's per-pass profile of each set; RES_RUN=1 runs each scene as rockprep wrote it
# (`rockflow run`, double) beside the bulk liquid in double.
# RES_SWEEP lists resolutions (among RESOLUTIONS) to sweep as docs/accuracy.md's resolution rows
# do: g = 0.04 / (rc per voxel)^2, a warm-up of 2,000 (rc per voxel)^2 steps or 2,000, blocks of
# 1,000 steps, 10 measured.
if [ "${RESOLUTION:-1}" = 1 ]; then
resolutions=${RESOLUTIONS:-0.5 0.85 1.2 1.6 2.0}
IFS=';' read -ra sets <<< "${RES_SWITCHES:-}"
[ ${#sets[@]} = 0 ] && sets=("")
rock_bench() {  # rock_bench BINARY RPV [bench options]
  local bin=$1 v=$2
  shift 2
  $B/$bin bench --backend cuda --case rock --solid $W/R$v/solid.h5 \
    --particles ${RES_PARTICLES:-4450000} --steps 200 "$@" 2>&1
}
for v in $resolutions; do
  $B/rockprep run .carry/rock/berea_100_to_300.npz --labels true=pore,false=solid \
    --crop 0:50,0:50,0:50 --spacing 5.345,5.345,5.345 --unit um --layout permeability \
    --threads $(nproc) --seed 7 --rc-per-voxel $v --out $W/R$v > $W/prepR.log 2>&1 || tail -3 $W/prepR.log
  grep summary $W/prepR.log | sed "s/^/resolution $v /"
done
for round in $(seq ${ROUNDS:-2}); do
  for v in $resolutions; do
    for bin in ${RES_BINS:-rockflow}; do
      # a reference binary older than a switch runs only the sets it knows (read once: a grep -q
      # that closes the pipe early would fail the pipeline under pipefail)
      help=$($B/$bin bench --help 2>&1)
      for set in "${sets[@]}"; do
        [ -n "$set" ] && [[ $help != *"${set%% *}"* ]] && continue
        line=$(rock_bench $bin $v $set | tail -1)
        echo "resolution $v $bin${set:+ $set} r$round: $line"
      done
    done
    m=$(echo "$line" | sed -n 's/.*, \([0-9]*\) mobile.*/\1/p')
    [ -n "$m" ] && $B/rockflow bench --backend cuda --case bulk --particles $m --steps 200 2>&1 |
      tail -1 | sed "s/^/resolution $v r$round bulk: /"
  done
done
for v in $resolutions; do
  if [ "${RES_PROFILE:-0}" = 1 ]; then
    for set in "${sets[@]}"; do
      rock_bench rockflow $v $set --profile | tail -1 | sed "s/^/resolution $v${set:+ $set} profile: /"
    done
  fi
  if [ "${RES_RUN:-0}" = 1 ]; then
    $B/rockflow run $W/R$v/scene.toml --backend cuda --out $W/runR > $W/run.txt 2>&1
    echo "resolution $v run rc=$?: $(grep 'done:' $W/run.txt | sed 's/; outputs in.*//')"
    python3 -c "import json; s=json.load(open('$W/runR/summary.json')); print('resolution $v run: buried', s.get('buried_particles'), 'solid', s.get('solid',{}).get('invariant'), 'T', s['final_temperature'])"
    m=$(python3 -c "import json; print(int(json.load(open('$W/runR/summary.json'))['mobile_particles']))")
    $B/rockflow bench --backend cuda --case bulk --particles $m --steps 200 --precision double 2>&1 |
      tail -1 | sed "s/^/resolution $v run's bulk: /"
  fi
  if [[ " ${RES_SWEEP:-} " == *" $v "* ]]; then
    read -r g warm < <(python3 -c "print(round(0.04 / $v ** 2, 4), max(2000, round(2000 * $v ** 2)))")
    t=$(date +%s.%N)
    $B/rockflow sweep $W/R$v/scene.toml --backend cuda --out $W/sweepR --forces $g \
      --viscosity 6.111 --viscosity-error 0.041 --warmup $warm --block-steps 1000 --window 2 \
      --measure-blocks 10 > $W/sweep.txt 2>&1
    echo "resolution $v sweep g=$g warm-up $warm rc=$? $(python3 -c "print(round($(date +%s.%N) - $t, 1))") s: $(grep -E 'k = ' $W/sweep.txt | tail -1)"
    python3 -c "import json; s=json.load(open('$W/sweepR/sweep.json')); print('resolution $v sweep solid', s.get('solid'))" 2>&1 | tail -1
  fi
  rm -rf $W/R$v $W/runR $W/sweepR
done
fi
echo done
