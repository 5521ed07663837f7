#!/bin/bash
# How often a fresh Berea 50^3 permeability scene runs away, per variant of its set-up
# (docs/walls.md, "One turn per step"; results in docs/perf/2026-12-04-runaway-study.txt).
# Runs on the GPU machine over a copy of the repo with .carry/gpu (ROCKPREP=1
# scripts/gpu/build_bundle.sh) and .carry/rock/berea_100_to_300.npz (copied from
# ../shared/data/rocks by hand, never committed):
#   N=24 STEPS=4000 G=0.04 VARIANTS="base kappa1 specular dt005 double" bash scripts/gpu/runaway_study.sh
# Each run: rockflow run of the scene (seed 1..N) at g = G for STEPS flow steps, 4 at a time.
set -u
mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
export LD_LIBRARY_PATH=$PWD/.carry/gpu/lib:/tmp/rockprep-libs
B=$PWD/.carry/gpu/bin; R=$PWD/.carry/rock
N=${N:-24}; STEPS=${STEPS:-4000}; G=${G:-0.04}; PAR=${PAR:-4}
VARIANTS=${VARIANTS:-"base kappa1 specular dt005 double"}
t0=$(date +%s)
timeout 120 $B/rockprep run $R/berea_100_to_300.npz --labels true=pore,false=solid --crop 0:50,0:50,0:50 \
  --spacing 5.345,5.345,5.345 --unit um --layout permeability --out /tmp/base --tile-cache /tmp/tc > /tmp/base.log 2>&1 || { echo prep failed; tail -3 /tmp/base.log; }
make_variant() { # name
  local d=/tmp/v-$1; rm -rf $d; cp -r /tmp/base $d; local f=$d/scene.toml
  sed -i "s/^body_force = \[0.02,/body_force = [$G,/; s/^steps = 2000$/steps = $STEPS/" $f
  case $1 in
    kappa1) sed -i 's/^wall_density = 8.0.*/&\nmax_dissipation_factor = 1.0/' $f ;;
    specular) sed -i 's/^wall_density = 8.0.*/&\nreflection = "specular"/' $f ;;
    dt005) python3 - $f $STEPS <<'P'
import sys,re
p,steps=sys.argv[1],int(sys.argv[2]); s=open(p).read()
s=s.replace('steps = %d\ndt = 0.01'%steps, 'steps = %d\ndt = 0.005'%(2*steps)); open(p,'w').write(s)
P
    ;;
    double) sed -i 's/^seed = 1$/seed = 1\nprecision = "double"/' $f ;;
  esac
}
one() { # variant seed
  local d=/tmp/v-$1-s$2; rm -rf $d; cp -r /tmp/v-$1 $d; sed -i "s/^seed = 1$/seed = $2/" $d/scene.toml
  timeout 120 $B/rockflow run $d/scene.toml --out $d/out --backend cuda > $d.log 2>&1
  local rc=$?
  echo "$1 seed $2 rc=$rc $(tr '\r' '\n' < $d.log | grep -E 'failure|error|done' | tail -1 | cut -c1-260)" >> /tmp/results.txt
  rm -rf $d
}
rm -f /tmp/results.txt
for v in $VARIANTS; do
  make_variant $v
  for s in $(seq 1 $N); do
    one $v $s &
    while [ $(jobs -r | wc -l) -ge $PAR ]; do sleep 0.2; done
  done
  wait
  echo "[$(( $(date +%s) - t0 )) s] $v: $(grep -c "^$v seed.*rc=0" /tmp/results.txt) of $N completed; runaways: $(grep "^$v seed" /tmp/results.txt | grep -c runaway)"
done
grep -v "rc=0" /tmp/results.txt | sort | head -60
cp /tmp/results.txt $OUT/ 2>/dev/null
