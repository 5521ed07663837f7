#!/usr/bin/env bash
# Runs scenes with two rockflow binaries and says whether their outputs are identical: every CSV
# (comment lines dropped: they name the commit), every HDF5 file (h5dump, without the attributes
# that name the commit and version) and summary.json without its timing and version fields.
# For refactors that must not change a number (ARCHITECTURE.md: "every number unchanged").
#   scripts/compare_runs.sh OLD_ROCKFLOW NEW_ROCKFLOW SCENE.toml... [-- extra run options]
# Exit 0 when every scene matches; the first differences are printed otherwise.
set -uo pipefail
old=$1 new=$2
shift 2
scenes=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do scenes+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
extra=("$@")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
dump_h5() {  # h5dump without the attributes that name the build
  h5dump "$1" 2>&1 | tail -n +2 | awk '
    skip == 0 && /ATTRIBUTE "(git_commit|mesorock_version|version)"/ { skip = 1; depth = 0 }
    skip == 1 { depth += gsub(/{/, "{"); depth -= gsub(/}/, "}"); if (depth <= 0 && /}/) skip = 0; next }
    { print }'
}
strip_json() {
  python3 - "$1" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
for k in ("wall_seconds", "run_seconds", "mps", "mobile_mps", "git_commit", "mesorock_version",
          "scene_file"):
    j.pop(k, None)
print(json.dumps(j, sort_keys=True, indent=1))
PY
}
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .toml)
  for side in old new; do
    bin=$old; [ $side = new ] && bin=$new
    "$bin" run "$scene" --out "$work/$side/$name" --threads "${THREADS:-1}" \
      "${extra[@]}" >"$work/$side.$name.log" 2>&1
    echo $? >"$work/$side.$name.rc"
  done
  diffs=()
  [ "$(cat "$work/old.$name.rc")" = "$(cat "$work/new.$name.rc")" ] || diffs+=("exit code")
  for f in $(cd "$work/old/$name" 2>/dev/null && find . -type f | sort); do
    a="$work/old/$name/$f" b="$work/new/$name/$f"
    if [ ! -f "$b" ]; then diffs+=("$f missing"); continue; fi
    case "$f" in
      *.csv) cmp -s <(grep -v '^#' "$a") <(grep -v '^#' "$b") || diffs+=("$f") ;;
      *.h5) cmp -s <(dump_h5 "$a") <(dump_h5 "$b") || diffs+=("$f") ;;
      */summary.json) cmp -s <(strip_json "$a") <(strip_json "$b") || diffs+=("$f") ;;
    esac
  done
  extra_files=$(comm -13 <(cd "$work/old/$name" 2>/dev/null && find . -type f | sort) \
    <(cd "$work/new/$name" 2>/dev/null && find . -type f | sort))
  [ -z "$extra_files" ] || diffs+=("new files: $extra_files")
  if [ ${#diffs[@]} -eq 0 ]; then
    echo "same: $scene ($(cd "$work/old/$name" 2>/dev/null && find . -type f | wc -l) files)"
  else
    echo "DIFFERENT: $scene: ${diffs[*]}"
    status=1
  fi
done
exit $status
