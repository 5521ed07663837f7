#!/usr/bin/env bash
# What the frozen particles' sums and the wall corrector cost a rock step (docs/benchmarks.md,
# "What the frozen particles' sums and the corrector cost"): the bench's rock case from rockprep's
# Berea 50^3 scene at each rc per voxel in RESOLUTIONS, run by rockflow and by two timing-bound
# builds that compute wrong physics on purpose: rockflow-bsums (MESOROCK_BOUND_NO_FROZEN_SUMS: the
# pair passes visit the mobile part alone) and rockflow-bboth (that and MESOROCK_BOUND_NO_CORRECTOR:
# no wall correction either); ROUNDS rounds alternating, and the bulk liquid of each mobile count.
# Bundle: .carry/gpu/bins.tar.xz with rockflow, rockflow-bsums, rockflow-bboth and rockprep
# (scripts/gpu/build_bundle.sh, VARIANTS and ROCKPREP=1), the image in .carry/rock.
set -uo pipefail
cd "$(dirname "$0")/../.."
export LD_LIBRARY_PATH=$PWD/.carry/gpu/lib:/tmp/rockprep-libs
mkdir -p .carry/gpu/bin && tar xJf .carry/gpu/bins.tar.xz -C .carry/gpu/bin
mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
B=$PWD/.carry/gpu/bin W=/tmp/bounds
mkdir -p $W
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
cat .carry/gpu/COMMIT
for v in ${RESOLUTIONS:-0.5 0.85 2.0}; do
  $B/rockprep run .carry/rock/berea_100_to_300.npz --labels true=pore,false=solid \
    --crop 0:50,0:50,0:50 --spacing 5.345,5.345,5.345 --unit um --layout permeability \
    --threads "$(nproc)" --seed 7 --rc-per-voxel "$v" --out $W/R$v > $W/prep.log 2>&1 || tail -3 $W/prep.log
done
for v in ${RESOLUTIONS:-0.5 0.85 2.0}; do
  for round in $(seq "${ROUNDS:-2}"); do
    for bin in rockflow rockflow-bsums rockflow-bboth; do
      line=$($B/$bin bench --backend cuda --case rock --solid $W/R$v/solid.h5 --particles 4450000 \
        --steps 200 2>&1 | tail -1)
      echo "rock $v $bin r$round: $line"
    done
  done
  m=$(echo "$line" | sed -n 's/.*, \([0-9]*\) mobile.*/\1/p')
  [ -n "$m" ] && $B/rockflow bench --backend cuda --case bulk --particles "$m" --steps 200 2>&1 |
    tail -1 | sed "s/^/bulk $v: /"
  $B/rockflow bench --backend cuda --case rock --solid $W/R$v/solid.h5 --particles 4450000 \
    --steps 200 --profile 2>&1 | tail -2 | sed "s/^/profile $v: /"
done
echo done
