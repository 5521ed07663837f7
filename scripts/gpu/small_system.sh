#!/usr/bin/env bash
# The 20,000-particle bulk liquid (issue 24: 300 MPS/s on one card) by each binary in BINS
# (default: every rockflow* in the bundle), alternating, ROUNDS times (default 3); then each
# binary's per-pass profile, and, where nsys is installed, the current binary's kernels with
# graphs on (nsys's CUDA GPU kernel summary). Bundle as for acceptance.sh.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
bins=${BINS:-$(cd $B && ls rockflow* | tr '\n' ' ')}
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,clocks.sm --format=csv,noheader
cat .carry/gpu/COMMIT
small() {  # the bench line, or with --profile the per-pass line
  $B/$1 bench --backend cuda --case bulk --particles 20000 --steps 5000 "${@:2}" 2>&1 |
    grep -E "^bench|per-step" | tail -1
}
for round in $(seq ${ROUNDS:-3}); do
  for bin in $bins; do echo "small $bin r$round: $(small $bin)"; done
done
for bin in $bins; do echo "small $bin profile: $(small $bin --profile)"; done
for bin in $bins; do echo "small $bin watchdog off: $(small $bin --watchdog off)"; done
if command -v nsys > /dev/null; then
  nsys profile -o $O/small --force-overwrite true --stats=false \
    $B/rockflow bench --backend cuda --case bulk --particles 20000 --steps 2000 > /dev/null 2>&1
  nsys stats --report cuda_gpu_kern_sum --format csv $O/small.nsys-rep 2>/dev/null |
    cut -d, -f1-4,9 | head -25
  rm -f $O/small.nsys-rep $O/small.sqlite
else
  echo "no nsys"
fi
