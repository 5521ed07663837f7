#!/usr/bin/env bash
# What accuracy costs, in one command: runs `rockflow study` (error against time for the time
# step, precision, resolution, cell-list settings and each effect; pipeline/flow/study.cpp) and
# turns its output into a page with tables and plots (scripts/accuracy_report.py).
#
#   bash scripts/accuracy.sh [--backend cpu|cuda] [--size tiny|small|full] [--threads N]
#                            [--only timestep,precision,resolution,reorder,effects]
#                            [--rockflow BIN] [--packing-json FILE | --packing] --out DIR
#
# Writes DIR/accuracy.md and DIR/accuracy/ (the PNG plots, study.json, one CSV per study, and the
# packing JSON when given). docs/accuracy.md is the committed copy of a GPU run:
#   bash scripts/accuracy.sh --backend cuda --size full --out OUT && cp -r OUT/accuracy.md OUT/accuracy docs/
# --size small runs on a 2-core CPU in a few minutes; full is sized for one H200 (a few minutes).
# --packing-json FILE shows the lattice-vs-tile packing table from
#   `rockprep validate packing-walls --json` (rockprep needs OpenVDB: run it on the CPU machine);
# --packing runs that command here ($ROCKPREP, default build/bin/rockprep).
set -euo pipefail
cd "$(dirname "$0")/.."

backend=cpu size=small threads="" only="" out="" packing_json="" run_packing=0
rockflow=${ROCKFLOW:-build/bin/rockflow}
while [ $# -gt 0 ]; do
  case "$1" in
    --backend) backend=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --rockflow) rockflow=$2; shift 2 ;;
    --packing-json) packing_json=$2; shift 2 ;;
    --packing) run_packing=1; shift ;;
    -h|--help) sed -n 2,18p "$0"; exit 0 ;;
    *) echo "accuracy.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { echo "accuracy.sh: --out DIR is required" >&2; exit 2; }
[ -x "$rockflow" ] || { echo "accuracy.sh: $rockflow: no rockflow binary (build it, or --rockflow BIN)" >&2; exit 2; }
[ -z "$packing_json" ] || [ -f "$packing_json" ] || { echo "accuracy.sh: $packing_json: no such file" >&2; exit 2; }
# Binaries carried to the GPU machine keep their extra libraries in ../lib (scripts/gpu).
libdir="$(dirname "$rockflow")/../lib"
[ -d "$libdir" ] && export LD_LIBRARY_PATH="$(cd "$libdir" && pwd):${LD_LIBRARY_PATH:-}"

# A Python with numpy and matplotlib (Debian's python3-matplotlib lives in /usr/bin/python3).
python=""
for p in python3 /usr/bin/python3; do
  if command -v "$p" >/dev/null 2>&1 && "$p" -c 'import numpy, matplotlib' 2>/dev/null; then
    python=$p
    break
  fi
done

data="$out/accuracy"
mkdir -p "$data"
args=(study --size "$size" --backend "$backend" --out "$data")
[ -n "$threads" ] && args+=(--threads "$threads")
[ -n "$only" ] && args+=(--only "$only")
echo "accuracy.sh: $rockflow ${args[*]}" >&2
"$rockflow" "${args[@]}"

if [ "$run_packing" = 1 ] && [ -z "$packing_json" ]; then
  rockprep=${ROCKPREP:-build/bin/rockprep}
  psize=$size
  [ "$psize" = tiny ] && psize=small
  if [ -x "$rockprep" ] && "$rockprep" validate --list 2>/dev/null | grep -qx packing-walls; then
    echo "accuracy.sh: $rockprep validate packing-walls --size $psize --json" >&2
    # The case exits 1 when a judged quantity fails; its JSON is still the measurement.
    "$rockprep" validate packing-walls --size "$psize" --json > "$data/.packing.json.partial" || true
    if "$python" -c 'import json,sys; json.loads(open(sys.argv[1]).read())' "$data/.packing.json.partial" 2>/dev/null; then
      mv "$data/.packing.json.partial" "$data/packing.json"
      packing_json="$data/packing.json"
    else
      rm -f "$data/.packing.json.partial"
      echo "accuracy.sh: packing-walls gave no JSON; the page says it was not measured" >&2
    fi
  else
    echo "accuracy.sh: $rockprep has no 'validate packing-walls'; the page says it was not measured" >&2
  fi
fi

report=(--study "$data/study.json" --out "$out")
[ -n "$packing_json" ] && report+=(--packing-json "$packing_json")
if [ -z "$python" ]; then
  # The study is done and kept: the page can be made on any machine with matplotlib.
  echo "accuracy.sh: no python3 with numpy and matplotlib here (scripts/setup.sh installs them);" \
    "the study is in $data; make the page with: python3 scripts/accuracy_report.py ${report[*]}" >&2
  exit 2
fi
"$python" scripts/accuracy_report.py "${report[@]}"
