#!/usr/bin/env bash
# Sample 03: the physics validation suite. Runs `rockflow validate CASE --json` for every case
# that `rockflow validate --list` names, writes each case's verdict (every quantity with its
# measured value, error, reference, source and tolerance, and the notes) to OUT/CASE.json and
# its progress log to OUT/CASE.log, and ends with a table of verdicts (OUT/summary.txt). Exit
# status 1 when any case failed.
#
#   bash samples/03_validation_suite/run.sh                        # small sizes, CPU (CI's set)
#   bash samples/03_validation_suite/run.sh --size full --backend cuda   # the GPU machine
#   bash samples/03_validation_suite/run.sh perm-slit perm-tube    # only these cases
#
# Options: --size small|full (default small), --rockflow PATH (default build/bin/rockflow),
# --out DIR (default out/03_validation_suite); other options (--backend, --threads,
# --density-kernel) go to `rockflow validate`; bare words are case names.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
rockflow="$here/../../build/bin/rockflow"
out="out/03_validation_suite"
size="small"
cases=()
extra=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --size) size="$2"; shift ;;
    --rockflow) rockflow="$2"; shift ;;
    --out) out="$2"; shift ;;
    --backend|--threads|--density-kernel) extra+=("$1" "$2"); shift ;;
    -*) echo "run.sh: unknown option $1" >&2; exit 2 ;;
    *) cases+=("$1") ;;
  esac
  shift
done
if [[ ${#cases[@]} -eq 0 ]]; then
  mapfile -t cases < <("$rockflow" validate --list)
fi
mkdir -p "$out"
failed=0
summary=()
for c in "${cases[@]}"; do
  echo "=== $c ($size) ===" >&2
  start=$(date +%s)
  "$rockflow" validate "$c" --size "$size" --json ${extra[@]+"${extra[@]}"} > "$out/$c.json" \
    2> >(tee "$out/$c.log" >&2)
  status=$?
  seconds=$(( $(date +%s) - start ))
  verdict=$([[ $status -eq 0 ]] && echo PASS || echo FAIL)
  [[ $status -eq 0 ]] || failed=1
  summary+=("$(printf '%-22s %-7s %6s s' "$c" "$verdict" "$seconds")")
done
printf '%s\n' "case                   verdict  time" "${summary[@]}" | tee "$out/summary.txt"
echo "reports in $out (CASE.json: every quantity with its reference, source and tolerance)"
exit $failed
