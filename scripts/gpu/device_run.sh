#!/usr/bin/env bash
# Runs on the GPU machine over a copy of the repo with .carry/gpu (see build_bundle.sh):
# GPU tests, validation cases with --backend cuda, and the benchmarks. Writes logs to $OUT
# (or ./gpu-out) and prints a short table last.
#   bash scripts/gpu/device_run.sh quick   # tests + small validation + 1-2 M benchmarks
#   bash scripts/gpu/device_run.sh full    # + full-size validation + 16 M benchmarks
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

$bin/unit_gpu 2>&1 | tee "$out/unit_gpu.log" | tail -4
$bin/unit_sim 2>&1 | tee "$out/unit_sim.log" | tail -3

size=small
[ "$mode" = full ] && size=full
for c in ${CASES:-eos-dpd eos-mdpd conservation slab viscosity}; do
  $bin/rockflow validate $c --size $size --backend cuda --json 2>>"$out/validate.log" | tee -a "$out/validate.jsonl" | cut -c1-200
done

bench() { $bin/rockflow bench --backend cuda --json "$@" 2>>"$out/bench.log" | tee -a "$out/bench.jsonl"; }
bench --case porous --particles 2100000 --steps 200 --compare-cpu --threads $(nproc)
bench --case bulk --particles 1000000 --steps 200
if [ "$mode" = full ]; then
  bench --case porous --particles 16000000 --steps 100
  bench --case bulk --particles 16000000 --steps 100
fi
python3 - "$out" <<'PY'
import json, sys, pathlib
out = pathlib.Path(sys.argv[1])
print("\n%-8s %10s %8s %10s %10s" % ("case", "particles", "backend", "MPS/s", "cpu MPS/s"))
for line in (out / "bench.jsonl").read_text().splitlines():
    j = json.loads(line)
    cpu = j.get("cpu", {}).get("mps", float("nan"))
    print("%-8s %10d %8s %10.1f %10.2f" % (j["case"], j["particles"], j["backend"], j["mps"], cpu))
for line in (out / "validate.jsonl").read_text().splitlines():
    j = json.loads(line)
    print("validate %-14s %s" % (j["case"], "PASS" if j["pass"] else "FAIL"))
PY
