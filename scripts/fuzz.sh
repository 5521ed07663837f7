#!/usr/bin/env bash
# Fuzzes the scene parser and every image loader with libFuzzer (clang, AddressSanitizer and
# UndefinedBehaviorSanitizer) for a bounded time each. A separate build (build-fuzz, clang) leaves
# the normal gcc build alone. Crashing inputs land in build-fuzz/findings/<target>/; once the bug
# is fixed, copy the input to tests/data/fuzz/<target>/ so the normal build replays it (unit tests
# *FuzzRegressions*) and every later fuzz run starts from it.
#
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s; all targets)
#   targets: scene tiff npy npz mhd raw hdf5
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scene tiff npy npz mhd raw hdf5)

generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
[ -f build-fuzz/CMakeCache.txt ] && generator=()
CC=clang CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DMESOROCK_ENABLE_CUDA=OFF -DMESOROCK_FUZZ=ON >/dev/null
cmake --build build-fuzz --parallel "$(nproc)" >/dev/null

work=build-fuzz/run
rm -rf "$work"
mkdir -p "$work/tmp" build-fuzz/findings
export TMPDIR="$PWD/$work/tmp"
build-fuzz/bin/fuzz_make_seeds "$work/corpus" >/dev/null
k=0
for f in tests/data/scenes/*.toml tests/data/scenes/*/*.toml samples/*/scene.toml; do
  cp "$f" "$work/corpus/scene/$k-$(basename "$f")"
  k=$((k + 1))
done

# One target per core at a time (each fuzzer is one process on one core): the same seconds per
# target in about 1 / nproc of the time.
run_target() {
  local t=$1
  mkdir -p "build-fuzz/findings/$t"
  local kept=()  # the crashes found before (tests/data/fuzz/<target>), read as corpus too
  [ -d "tests/data/fuzz/$t" ] && kept=("tests/data/fuzz/$t")
  # -timeout: one input running longer than 10 s is a hang; -rss_limit_mb bounds memory.
  if build-fuzz/bin/fuzz_"$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
       -max_len=65536 -print_final_stats=1 -artifact_prefix="build-fuzz/findings/$t/" \
       "$work/corpus/$t" "${kept[@]}" >"$work/$t.log" 2>&1; then
    echo ok >"$work/$t.status"
  else
    echo failed >"$work/$t.status"
  fi
}
running=0
for t in "${targets[@]}"; do
  run_target "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$(nproc)" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait
failed=()
for t in "${targets[@]}"; do
  if [ "$(cat "$work/$t.status" 2>/dev/null)" = ok ]; then
    echo "fuzz: $t: ok ($(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "$work/$t.log" |
      grep -o '[0-9]*$') runs in ${seconds} s)"
  else
    echo "fuzz: $t: FAILED; the crashing input is in build-fuzz/findings/$t/; log:"
    grep -a -E "ERROR|SUMMARY|runtime error|uncaught|what\(\)" "$work/$t.log" | head -5 || true
    failed+=("$t")
  fi
done
rm -rf "$work/tmp"
[ ${#failed[@]} -eq 0 ] || { echo "fuzz: failed: ${failed[*]}"; exit 1; }
echo "fuzz: all ${#targets[@]} targets ran ${seconds} s each without a finding"
