#!/usr/bin/env bash
# Runs on the GPU machine over a copy of the repo with .carry/gpu (see build_bundle.sh):
# GPU tests, validation cases with --backend cuda, and the benchmarks. Writes logs to $OUT
# (or ./gpu-out) and prints a short table last.
#   bash scripts/gpu/device_run.sh quick   # tests + small validation + 1-2 M benchmarks
#   bash scripts/gpu/device_run.sh full    # + full-size validation + 16 M benchmarks
#   bash scripts/gpu/device_run.sh perf    # tests + benchmarks of every carried rockflow variant
#                                          # (build_bundle.sh VARIANTS=...), side by side, with
#                                          # per-pass profiles; no validation
#   bash scripts/gpu/device_run.sh watchdog  # tests + the watchdog's cost: each case timed with
#                                          # the watchdog off and on in one process (sim/watchdog.h)
#   bash scripts/gpu/device_run.sh verify  # tests + every validation case small, the wall,
#                                          # flooding and permeability cases full; the watchdog's
#                                          # cost; the one-rank MPI path's cost
#   bash scripts/gpu/device_run.sh study   # the accuracy study at full size (rockflow study:
#                                          # study.json and CSVs; scripts/accuracy_report.py here
#                                          # turns them into docs/accuracy.md)
#   bash scripts/gpu/device_run.sh samples # carried prepared samples (.carry/samples, prepared
#                                          # on the CPU machine by rockprep): the shale
#                                          # permeability sweep on the GPU, and the load-balance
#                                          # benchmark (4 CPU ranks, slabs vs RCB)
set -uo pipefail
mode=${1:-quick}
out=${OUT:-gpu-out}
mkdir -p "$out"
export LD_LIBRARY_PATH="$PWD/.carry/gpu/lib:${LD_LIBRARY_PATH:-}"
bin=.carry/gpu/bin
log() { echo "$@" | tee -a "$out/summary.txt"; }
{
  echo "date: $(date -u +%Y-%m-%dT%H:%MZ)  commit: $(cat .carry/gpu/COMMIT 2>/dev/null)"
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  echo "cpu: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
} | tee "$out/summary.txt"

if [ -z "${SKIP_TESTS:-}" ]; then  # SKIP_TESTS=1: the carry may hold rockflow alone
$bin/unit_gpu 2>&1 | tee "$out/unit_gpu.log" | tail -4
$bin/unit_sim 2>&1 | tee "$out/unit_sim.log" | tail -3
# The domain decomposition on the GPU: 2 ranks sharing the device, against the single-rank GPU
# solver (tests/unit/mpi), when mpirun is there.
if command -v mpirun >/dev/null; then
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 MESOROCK_TEST_BACKEND=cuda \
    mpirun -np 2 --oversubscribe $bin/unit_mpi 2>&1 | tee "$out/unit_mpi.log" | tail -3
fi
fi

if [ "$mode" = study ]; then
  start=$(date +%s)
  # study.json and the CSVs in one archive (the device tool brings back only a few files).
  rm -rf /tmp/mesorock-study && mkdir -p /tmp/mesorock-study
  $bin/rockflow study --size full --backend cuda --out /tmp/mesorock-study/accuracy \
    ${STUDY_ONLY:+--only $STUDY_ONLY} 2>&1 | tee "$out/study.log" | grep -v '\r' | tail -5
  tar czf "$out/accuracy.tgz" -C /tmp/mesorock-study accuracy
  log "study: $(( $(date +%s) - start )) s"
  # The watchdog's cost after the study (the same binary): off and on in one process.
  for p in ${WATCHDOG_CASES:-"porous 2100000 400" "bulk 1000000 400" "porous 16000000 200"}; do
    set -- $p
    $bin/rockflow bench --backend cuda --json --case $1 --particles $2 --steps $3 \
      --watchdog compare 2>>"$out/bench.log" | tee -a "$out/bench.jsonl" | cut -c1-300
  done
  exit 0
fi
if [ "$mode" = samples ]; then
  # Results go to one archive, re-packed after every stage (the device tool returns only a few
  # files, and a run cut off by its time limit keeps what the last pack holds): $out/results.tgz.
  res=/tmp/mesorock-results/results
  rm -rf "$res" && mkdir -p "$res"
  pack() { tar czf "$out/results.tgz.part" -C "$(dirname "$res")" results && mv "$out/results.tgz.part" "$out/results.tgz"; }
  # 1. The accuracy study, alone on the GPU (its timings must not share the machine).
  if [ -z "${SKIP_STUDY:-}" ]; then
    start=$(date +%s)
    $bin/rockflow study --size full --backend cuda --out "$res/accuracy" 2>&1 | tr '\r' '\n' > "$res/study.log"
    log "study: $(( $(date +%s) - start )) s; $(tail -1 "$res/study.log")"
    pack
  fi
  # 2. The shale permeability sweep (samples/06_shale_permeability --size full, prepared with
  #    --prep-only on the CPU machine) on the GPU, in the background...
  if [ -f .carry/samples/shale/scene.toml ]; then
    rm -rf /tmp/shale06 && mkdir -p /tmp/shale06 && cp -r .carry/samples/shale /tmp/shale06/setup
    ( start=$(date +%s)
      bash samples/06_shale_permeability/run.sh --size full --out /tmp/shale06 --sweep-only \
        --backend cuda --rockflow "$bin/rockflow" 2>&1 | tr '\r' '\n' > "$res/shale_sweep.log"
      echo "exit $? after $(( $(date +%s) - start )) s" >> "$res/shale_sweep.log"
      cp -r /tmp/shale06/sweep "$res/shale_sweep" ) &
    sweep_pid=$!
  fi
  # 3. ...while the CPU cores run the load-balance benchmark: the flooding set-up of
  #    samples/01 (rockprep run, 10,100 steps) on 4 CPU ranks: equal slabs along the flow axis,
  #    RCB along it, and RCB free to cut any axis.
  if [ -f .carry/samples/flood/scene.toml ] && command -v mpirun >/dev/null; then
    for spec in slabs:x rcb:x rcb:xyz; do
      method=${spec%%:*}
      axes=$(echo "${spec#*:}" | sed 's/./"&", /g; s/, $//')
      name=${method}_${spec#*:}
      dir=/tmp/lb_$name
      rm -rf "$dir" && mkdir -p "$dir" && cp .carry/samples/flood/particles.h5 "$dir/"
      { cat .carry/samples/flood/scene.toml
        printf '\n[decomposition]\nmethod = "%s"\naxes = [%s]\nrebalance_every = 1000\n' \
          "$method" "$axes"
      } > "$dir/scene.toml"
      start=$(date +%s)
      OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=${LB_THREADS:-3} \
        timeout ${LB_TIMEOUT:-280} mpirun -np 4 --bind-to none $bin/rockflow run "$dir/scene.toml" \
        --out "$dir/out" --threads ${LB_THREADS:-3} > "$res/lb_$name.log" 2>&1
      log "load balance $name: exit $?, $(( $(date +%s) - start )) s"
      mkdir -p "$res/lb_$name"
      cp "$dir/scene.toml" "$res/lb_$name/"
      find "$dir/out" -maxdepth 1 -type f \( -name '*.csv*' -o -name '*.json*' \) -exec cp {} "$res/lb_$name/" \;
      pack
    done
  fi
  [ -n "${sweep_pid:-}" ] && wait "$sweep_pid"
  log "shale sweep: $(tail -1 "$res/shale_sweep.log" 2>/dev/null)"
  # 4. The two small cases changed after the verify run, again on the GPU.
  for c in ${RECHECK:-no-penetration darcy-linearity}; do
    $bin/rockflow validate $c --size small --backend cuda --json 2>>"$res/validate.log" >> "$res/validate.jsonl"
    log "validate $c small cuda: exit $?"
  done
  pack
  exit 0
fi

size=small
[ "$mode" = full ] && size=full
[ "$mode" = perf ] && CASES=${CASES:-none}
[ "$mode" = watchdog ] && CASES=${CASES:-none}
[ "$mode" = verify ] && CASES=${CASES:-$($bin/rockflow validate --list | tr '\n' ' ')}
for c in ${CASES:-eos-dpd eos-mdpd conservation slab viscosity poiseuille-walls no-penetration flooding-mini}; do
  [ "$c" = none ] && continue
  $bin/rockflow validate $c --size $size --backend cuda --json 2>>"$out/validate.log" | tee -a "$out/validate.jsonl" | cut -c1-200
done
if [ "$mode" = verify ]; then
  for c in ${FULL_CASES:-no-penetration flooding-mini perm-slit perm-tube perm-sphere-array darcy-linearity}; do
    $bin/rockflow validate $c --size full --backend cuda --json 2>>"$out/validate_full.log" |
      python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); j["size"]="full"; print(json.dumps(j))' |
      tee -a "$out/validate.jsonl" | cut -c1-200
  done
fi

bench() {
  local exe=$1
  shift
  $exe bench --backend cuda --json "$@" 2>>"$out/bench.log" |
    python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); j["binary"]=sys.argv[1]; print(json.dumps(j))' "$(basename $exe)" |
    tee -a "$out/bench.jsonl"
}
if [ "$mode" = perf ]; then
  # The main binary at every cell-list resolution, the variants at the default one.
  for exe in $bin/rockflow $bin/rockflow-*; do
    [ -x "$exe" ] || continue
    cells=${VARIANT_CELLS:-1}
    [ "$exe" = "$bin/rockflow" ] && cells=${CELLS:-"1 2 3"}
    for m in $cells; do
      for p in "porous 2100000 200" "bulk 1000000 200" "porous 16000000 100" "bulk 16000000 100"; do
        set -- $p
        bench $exe --case $1 --particles $2 --steps $3 --profile --cells-per-rc $m
      done
    done
  done
  bench $bin/rockflow --case porous --particles 2100000 --steps 200 --compare-cpu --threads $(nproc)
elif [ "$mode" = verify ]; then
  # The watchdog's cost, off and on in one process.
  for p in "porous 2100000 400" "bulk 1000000 400"; do
    set -- $p
    bench $bin/rockflow --case $1 --particles $2 --steps $3 --watchdog compare
  done
  # The one-rank MPI path: plain, under mpirun -np 1 (MPI started, one rank: the plain solver),
  # and the decomposed path forced on one rank (exchange, ghosts, hooks), side by side.
  bench $bin/rockflow --case porous --particles 2100000 --steps 300
  if command -v mpirun >/dev/null; then
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun -np 1 --bind-to none \
      $bin/rockflow bench --backend cuda --json --case porous --particles 2100000 --steps 300 \
      2>>"$out/bench.log" |
      python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); j["binary"]="mpirun-np1"; print(json.dumps(j))' |
      tee -a "$out/bench.jsonl"
  fi
  bench $bin/rockflow --case porous --particles 2100000 --steps 300 --decompose
elif [ "$mode" = watchdog ]; then
  for p in "porous 2100000 400" "bulk 1000000 400" "porous 16000000 200" "bulk 16000000 200"; do
    set -- $p
    bench $bin/rockflow --case $1 --particles $2 --steps $3 --watchdog compare
  done
else
  bench $bin/rockflow --case porous --particles 2100000 --steps 200 --compare-cpu --threads $(nproc)
  bench $bin/rockflow --case bulk --particles 1000000 --steps 200
  # What the decomposed (MPI) path costs on one GPU, next to the plain path above.
  bench $bin/rockflow --case porous --particles 2100000 --steps 200 --decompose
  if [ "$mode" = full ]; then
    bench $bin/rockflow --case porous --particles 16000000 --steps 100
    bench $bin/rockflow --case bulk --particles 16000000 --steps 100
  fi
fi
python3 - "$out" <<'PY'
import json, sys, pathlib
out = pathlib.Path(sys.argv[1])
print("\n%-18s %-8s %10s %3s %10s %10s %6s  %s" % ("binary", "case", "particles", "c/r", "MPS/s", "cpu MPS/s", "B/p", "passes ms"))
for line in (out / "bench.jsonl").read_text().splitlines():
    j = json.loads(line)
    cpu = j.get("cpu", {}).get("mps", float("nan"))
    passes = j.get("profile", "")
    passes = passes.replace("per-step GPU time over ", "").replace(" steps (ms):", ":")
    print("%-18s %-8s %10d %3s %10.1f %10.2f %6.0f  %s" % (j.get("binary", ""), j["case"], j["particles"], j.get("cells_per_rc", ""), j["mps"], cpu, j.get("gpu_bytes_per_particle", 0), passes))
    if "watchdog_cost_percent" in j:
        print("    watchdog off %.1f MPS/s, on %.1f MPS/s: cost %.2f%% of a step" % (j["mps_watchdog_off"], j["mps_watchdog_on"], j["watchdog_cost_percent"]))
vpath = out / "validate.jsonl"
for line in (vpath.read_text().splitlines() if vpath.exists() else []):
    j = json.loads(line)
    print("validate %-14s %s" % (j["case"], "PASS" if j["pass"] else "FAIL"))
PY
