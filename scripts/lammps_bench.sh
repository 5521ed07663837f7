#!/usr/bin/env bash
# The same bulk mDPD liquid in LAMMPS DPD-MESO (`pair_style mdpd`) and in mesorock's CPU backend
# (`rockflow bench --case bulk`), side by side on one machine; one line per run with the code,
# threads, particles, steps, seconds and MPS/s (million particle-steps per second).
#
#   bash scripts/lammps_bench.sh [--particles N] [--steps S] [--threads "1 2"]
#                                [--precision double|single] [--rockflow BIN]
#                                [--rockflow-args "ARGS"] [--lammps-src DIR] [--lammps-build DIR]
#                                [--lammps-warmup W] [--repeat R] [--only lammps|mesorock]
#                                [--out DIR]
#
# LAMMPS is built once from Debian's source package (Debian's binary package lacks DPD-MESO) into
# --lammps-build (env LAMMPS_BUILD, default ~/.cache/mesorock/lammps-build), only the DPD-MESO
# package, no MPI. --lammps-src (env LAMMPS_SRC) is the unpacked source tree; by default the
# script looks for ~/.cache/mesorock/lammps-src/lammps-*/ and, when none is there, runs
# `apt-get source lammps` in that folder (needs a deb-src line for bookworm; see
# docs/benchmarks.md). The LAMMPS deck is written by this script (DIR/in.bulk_mdpd) to match
# pipeline/flow/bench.cpp's bulk case: A = -40, B = 25, rd = 0.75, gamma = 4.5, kBT = 1,
# rho = 6.9, rc = 1, dt = 0.01, a cube of N / 6.9 rc^3 with N random particles at kBT = 1, then
# `steps` timed steps. rockflow bench warms up for steps / 10 (at least 5) steps; LAMMPS for
# --lammps-warmup steps (default 200 = 2 time units), because its cost depends on the state: the
# random start heats the liquid (kBT about 12 after 5 steps, back to 1.03 after 200), and while
# it is hot LAMMPS rebuilds its Verlet lists every step or two instead of every few steps.
# mesorock sorts by cell and scans the 27 cells every step, whatever the state. What differs
# between the two decks (density kernel, neighbour lists, random numbers) is listed in
# docs/benchmarks.md.
#
# LAMMPS's `pair mdpd` and `mdpd/rhosum` have no OPENMP variant, so LAMMPS runs on 1 thread only
# (its 2-core figure would need an MPI build and mpirun); mesorock runs at each --threads count.
# --repeat R runs the whole set R times, the codes alternating, so that a change of the machine's
# load hits both. The cpu% column is the CPU time the run got over its wall time: LAMMPS's own
# figure for the timed loop; for rockflow, the whole process's (set-up and warm-up included),
# out of 100% per thread. On a shared machine a run that got less than its threads' worth was
# slowed by other jobs; run it under `nice -n 19` there. Defaults: 200,000 particles, 60 steps
# (about 30 s per run on one core of the 2-core development machine), threads "1 2", double
# precision (as LAMMPS).
set -euo pipefail
cd "$(dirname "$0")/.."

particles=200000 steps=60 threads="1 2" precision=double only="" out="" rockflow_args=""
lammps_warmup=200 repeat=1
rockflow=${ROCKFLOW:-build/bin/rockflow}
cache=${XDG_CACHE_HOME:-$HOME/.cache}/mesorock
lammps_src=${LAMMPS_SRC:-}
lammps_build=${LAMMPS_BUILD:-$cache/lammps-build}
while [ $# -gt 0 ]; do
  case "$1" in
    --particles) particles=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --precision) precision=$2; shift 2 ;;
    --rockflow) rockflow=$2; shift 2 ;;
    --rockflow-args) rockflow_args=$2; shift 2 ;;
    --lammps-src) lammps_src=$2; shift 2 ;;
    --lammps-build) lammps_build=$2; shift 2 ;;
    --lammps-warmup) lammps_warmup=$2; shift 2 ;;
    --repeat) repeat=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n 2,36p "$0"; exit 0 ;;
    *) echo "lammps_bench.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$only" in ""|lammps|mesorock) ;; *) echo "lammps_bench.sh: --only lammps or mesorock" >&2; exit 2 ;; esac
case "$precision" in double|single) ;; *) echo "lammps_bench.sh: --precision double or single" >&2; exit 2 ;; esac
[[ "$particles" =~ ^[0-9]+$ && "$particles" -ge 1000 ]] || { echo "lammps_bench.sh: --particles must be an integer >= 1000" >&2; exit 2; }
[[ "$steps" =~ ^[0-9]+$ && "$steps" -ge 1 ]] || { echo "lammps_bench.sh: --steps must be a positive integer" >&2; exit 2; }
[[ "$repeat" =~ ^[1-9][0-9]*$ ]] || { echo "lammps_bench.sh: --repeat must be a positive integer" >&2; exit 2; }
[[ "$lammps_warmup" =~ ^[0-9]+$ ]] || { echo "lammps_bench.sh: --lammps-warmup must be an integer >= 0" >&2; exit 2; }
for t in $threads; do
  [[ "$t" =~ ^[1-9][0-9]*$ ]] || { echo "lammps_bench.sh: --threads takes positive integers (got $t)" >&2; exit 2; }
done
if [ "$only" != lammps ] && [ ! -x "$rockflow" ]; then
  echo "lammps_bench.sh: $rockflow: no rockflow binary (build it, or --rockflow BIN)" >&2
  exit 2
fi
if [ "$only" != lammps ] && [ ! -x /usr/bin/time ]; then
  echo "lammps_bench.sh: /usr/bin/time is needed for rockflow's cpu% (apt-get install time)" >&2
  exit 2
fi
if [ -z "$out" ]; then
  out=$(mktemp -d "${TMPDIR:-/tmp}/lammps_bench.XXXXXX")
fi
mkdir -p "$out"
results="$out/results.tsv"
printf 'code\tthreads\tparticles\tsteps\tseconds\tmps\tcpu_percent\tload_before\tload_after\n' > "$results"
printf '%-9s %7s %10s %6s %9s %8s %6s   %s\n' code threads particles steps seconds "MPS/s" "cpu%" \
  "load average before/after"

load() { cut -d' ' -f1 /proc/loadavg; }
row() {  # code threads particles steps seconds cpu% load_before load_after
  local mps
  mps=$(awk -v n="$3" -v s="$4" -v t="$5" 'BEGIN { printf "%.4f", n * s / t / 1e6 }')
  printf '%-9s %7s %10s %6s %9.3f %8s %6s   %s / %s\n' "$1" "$2" "$3" "$4" "$5" "$mps" "$6" "$7" "$8"
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$4" "$5" "$mps" "$6" "$7" "$8" \
    >> "$results"
}

# --- LAMMPS: source, build (once), deck, runs -------------------------------------------------
find_lammps_src() {
  if [ -z "$lammps_src" ]; then
    local root="$cache/lammps-src"
    lammps_src=$(find "$root" -mindepth 1 -maxdepth 1 -type d -name 'lammps-*' 2>/dev/null | sort | tail -1)
    if [ -z "$lammps_src" ]; then
      echo "lammps_bench.sh: no LAMMPS source under $root: running apt-get source lammps there" >&2
      mkdir -p "$root"
      (cd "$root" && apt-get source lammps) >&2 || {
        echo "lammps_bench.sh: apt-get source lammps failed: add a deb-src line for bookworm" \
             "(docs/benchmarks.md), apt-get update, or give --lammps-src DIR" >&2
        exit 2
      }
      lammps_src=$(find "$root" -mindepth 1 -maxdepth 1 -type d -name 'lammps-*' | sort | tail -1)
    fi
  fi
  [ -f "$lammps_src/cmake/CMakeLists.txt" ] || {
    echo "lammps_bench.sh: $lammps_src is not a LAMMPS source tree (no cmake/CMakeLists.txt)" >&2
    exit 2
  }
}

build_lammps() {
  if [ -x "$lammps_build/lmp" ]; then return; fi
  find_lammps_src
  echo "lammps_bench.sh: building LAMMPS from $lammps_src in $lammps_build (once)" >&2
  mkdir -p "$lammps_build"
  local gen=()
  if command -v ninja > /dev/null; then gen=(-G Ninja); fi
  # Only what the deck needs: DPD-MESO, OpenMP (BUILD_OMP, as the issue's figure), no MPI, no
  # image, compression or movie support, no tools.
  cmake -S "$lammps_src/cmake" -B "$lammps_build" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DPKG_DPD-MESO=ON -DBUILD_MPI=OFF -DBUILD_OMP=ON -DBUILD_SHARED_LIBS=OFF \
    -DWITH_JPEG=OFF -DWITH_PNG=OFF -DWITH_GZIP=OFF -DWITH_FFMPEG=OFF -DBUILD_TOOLS=OFF \
    -DBUILD_LAMMPS_SHELL=OFF -DBUILD_DOC=OFF > "$lammps_build/configure.log" 2>&1 || {
    tail -30 "$lammps_build/configure.log" >&2; exit 1; }
  cmake --build "$lammps_build" -j "${LAMMPS_JOBS:-2}" --target lmp > "$lammps_build/build.log" 2>&1 || {
    tail -30 "$lammps_build/build.log" >&2; exit 1; }
}

write_deck() {  # the deck matching `rockflow bench --case bulk --particles N`
  local L
  L=$(awk -v n="$particles" 'BEGIN { printf "%.12f", exp(log(n / 6.9) / 3) }')
  cat > "$out/in.bulk_mdpd" <<EOF
# Bulk mDPD liquid as pipeline/flow/bench.cpp's bulk case (written by scripts/lammps_bench.sh):
# A = -40, B = 25, rd = 0.75, gamma = 4.5, kBT = 1, rc = 1, rho = 6.9, dt = 0.01.
units           lj
dimension       3
boundary        p p p
atom_style      mdpd
comm_modify     vel yes
neighbor        0.3 bin
neigh_modify    every 1 delay 0 check yes

region          box block 0 $L 0 $L 0 $L units box
create_box      1 box
create_atoms    1 random $particles 7 box
mass            1 1.0

pair_style      hybrid/overlay mdpd/rhosum mdpd 1.0 1.0 7
pair_coeff      1 1 mdpd/rhosum 0.75
pair_coeff      1 1 mdpd -40 25 4.5 1.0 0.75

velocity        all create 1.0 7 loop geom dist gaussian
fix             integrate all mvv/dpd 0.5
timestep        0.01
thermo_style    custom step temp press
thermo          0

run             $lammps_warmup
run             $steps
EOF
}

run_lammps() {  # repeat index
  local log="$out/lammps_t1_r$1.log" before after
  before=$(load)
  OMP_NUM_THREADS=1 "$lammps_build/lmp" -in "$out/in.bulk_mdpd" -log "$log" -screen none
  after=$(load)
  # "Loop time of X on 1 procs for S steps with N atoms": the last one is the timed run.
  local loop seconds s n cpu
  loop=$(grep '^Loop time of' "$log" | tail -1)
  cpu=$(grep 'CPU use with' "$log" | tail -1 | sed -E 's/^([0-9.]+)%.*/\1/')
  seconds=$(awk '{ print $4 }' <<< "$loop")
  s=$(awk '{ print $9 }' <<< "$loop")
  n=$(awk '{ print $12 }' <<< "$loop")
  row lammps 1 "$n" "$s" "$seconds" "$cpu" "$before" "$after"
  # The timed run's summary: its thermo row (temperature at the end), time per section,
  # neighbour list builds.
  {
    head -1 "$log"
    echo "warm-up $lammps_warmup steps, then $s timed steps; Step Temp Press at the end:" \
      "$(grep -E '^ +[0-9]+ ' "$log" | tail -1 | tr -s ' ')"
    grep -E '^(Pair|Neigh|Comm|Modify|Other) +\|' "$log" | tail -5 |
      awk -F'|' '{ gsub(/ /, "", $1); gsub(/ /, "", $6); printf "%s %s%%  ", $1, $6 } END { print "" }'
    grep -E '^(Ave neighs/atom|Neighbor list builds|Dangerous builds)' "$log" | tail -3
  } | sed 's/^/  lammps: /' >&2
}

run_mesorock() {  # repeat index
  local t json before after seconds s n cpu
  for t in $threads; do
    before=$(load)
    # shellcheck disable=SC2086  # rockflow_args is a list of options
    json=$(OMP_NUM_THREADS=$t /usr/bin/time -f '%e %U %S' -o "$out/mesorock_t${t}_r$1.time" \
      "$rockflow" bench --backend cpu --case bulk --particles "$particles" --steps "$steps" \
      --threads "$t" --precision "$precision" --json $rockflow_args)
    after=$(load)
    echo "$json" > "$out/mesorock_t${t}_r$1.json"
    cpu=$(awk '{ printf "%.1f", 100 * ($2 + $3) / $1 }' "$out/mesorock_t${t}_r$1.time")
    seconds=$(sed -E 's/.*"seconds":([^,}]*).*/\1/' <<< "$json")
    s=$(sed -E 's/.*"steps":([^,}]*).*/\1/' <<< "$json")
    n=$(sed -E 's/.*"particles":([^,}]*).*/\1/' <<< "$json")
    row mesorock "$t" "$n" "$s" "$seconds" "$cpu" "$before" "$after"
  done
  [ "$1" -gt 1 ] || echo "  mesorock: $("$rockflow" --version 2>&1 | head -1), $precision precision, $(sed -E 's/.*"pass":"([^"]*)".*/\1/' <<< "$json")" >&2
}

if [ "$only" != mesorock ]; then
  build_lammps
  write_deck
  for t in $threads; do
    [ "$t" = 1 ] || echo "  lammps: $t threads not run: pair mdpd and mdpd/rhosum have no OPENMP variant" >&2
  done
fi
for ((r = 1; r <= repeat; r++)); do
  [ "$only" = mesorock ] || run_lammps "$r"
  [ "$only" = lammps ] || run_mesorock "$r"
done
echo "results: $results" >&2
