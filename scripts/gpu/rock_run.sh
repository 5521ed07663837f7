#!/usr/bin/env bash
# Real rock on the GPU machine (docs/validation.md, "Real rock"): runs over a copy of the repo
# with .carry/gpu (build_bundle.sh with ROCKPREP=1: rockflow, rockprep and the libraries that
# machine lacks) and .carry/rock (the images from ../shared/data/rocks and a tile database,
# copied there by hand: never committed). rockprep packs each crop there (seconds), rockflow runs
# it on the GPU. Results go to one archive, $OUT/rock.tgz, packed again after every job.
#   JOBS="tests leak res darcy" bash scripts/gpu/rock_run.sh
#     tests  GPU tests of the solid grid and the GPU-vs-CPU suite
#     leak   Berea crop 100^3 at 0.5 rc per voxel, 50,000 steps at g = 0.04, the leak
#            invariant every 1,000 steps (thermo.csv, summary.json)
#     res    Berea crop 50^3 at each of $RES rc per voxel, Leopard at $LEOPARD_RES: a sweep at
#            g = 0.04 / (rc per voxel)^2 (resolution study; the LBM references run on the CPU
#            machine from the solid.h5 files that come back)
#     darcy  Berea and Leopard crops 50^3 ($DARCY_ROCKS) at $DARCY_RES_BEREA and $DARCY_RES_LEOPARD
#            rc per voxel ("auto": rockprep's choice): sweeps at four forces spanning a factor
#            of 8 ($DARCY_FORCES_BEREA, ..._LEOPARD)
set -uo pipefail
out=${OUT:-gpu-out}
mkdir -p "$out"
res_dir=/tmp/mesorock-rock/rock
mkdir -p "$res_dir"
pack() { tar czf "$out/rock.tgz.part" -C "$(dirname "$res_dir")" rock && mv "$out/rock.tgz.part" "$out/rock.tgz"; }
bin=$PWD/.carry/gpu/bin
rock=$PWD/.carry/rock
# rockprep's libraries (OpenVDB and its chain; xz-packed to fit the carry limit).
if [ -f .carry/gpu/rockprep-libs.tar.xz ]; then
  mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
fi
export LD_LIBRARY_PATH="$PWD/.carry/gpu/lib:/tmp/rockprep-libs:${LD_LIBRARY_PATH:-}"
log() { echo "$@" | tee -a "$res_dir/summary.txt"; }
{
  echo "date: $(date -u +%Y-%m-%dT%H:%MZ)  commit: $(cat .carry/gpu/COMMIT 2>/dev/null)"
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  echo "cpu: $(nproc) cores"
} | tee "$res_dir/summary.txt"
JOBS=${JOBS:-"tests leak res"}
RES=${RES:-"0.5 0.75 1.0"}
DARCY_RES_BEREA=${DARCY_RES_BEREA:-0.75}
DARCY_RES_LEOPARD=${DARCY_RES_LEOPARD:-0.5}
DARCY_FORCES_BEREA=${DARCY_FORCES_BEREA:-0.018,0.036,0.071,0.142}
DARCY_FORCES_LEOPARD=${DARCY_FORCES_LEOPARD:-0.02,0.04,0.08,0.16}
DARCY_ROCKS=${DARCY_ROCKS:-"berea leopard"}
# The viscosity calibrations of earlier calls travel in .carry/rock/cache.
mkdir -p "$res_dir/cache" && cp .carry/rock/cache/*.json "$res_dir/cache/" 2>/dev/null
# "auto": rockprep's default, the rc per voxel it picks from the critical pore diameter.
rpv_option() { [ "$1" = auto ] || echo "--rc-per-voxel $1"; }
berea() {  # berea CROP RPV DIR [rockprep options]
  local crop=$1 rpv=$2 dir=$3
  shift 3
  $bin/rockprep run "$rock/berea_100_to_300.npz" --labels true=pore,false=solid --crop "$crop" \
    --spacing 5.345,5.345,5.345 --unit um $(rpv_option "$rpv") --layout permeability \
    --tiles "$rock/tiles.h5" --threads "$(nproc)" --out "$dir" "$@" > "$dir.prep.log" 2>&1
}
leopard() {  # leopard CROP RPV DIR [rockprep options]
  local crop=$1 rpv=$2 dir=$3
  shift 3
  $bin/rockprep run "$rock/image_Leopard_slice100.npy" --labels 1=pore,0=solid --crop "$crop" \
    --spacing 2.25,2.25,2.25 --unit um $(rpv_option "$rpv") --layout permeability \
    --tiles "$rock/tiles.h5" --threads "$(nproc)" --out "$dir" "$@" > "$dir.prep.log" 2>&1
}
sweep() {  # sweep DIR FORCES [options]
  local dir=$1 forces=$2
  shift 2
  local start=$(date +%s)
  $bin/rockflow sweep "$dir/scene.toml" --out "$dir/sweep" --forces "$forces" --backend cuda \
    --calibration full --viscosity-cache "$res_dir/cache" "$@" > "$dir/sweep.log" 2>&1
  log "sweep $(basename "$dir") g=$forces: exit $?, $(( $(date +%s) - start )) s: $(tail -1 "$dir/sweep.log" | tr '\r' ' ' | tail -c 200)"
}

for job in $JOBS; do
  start=$(date +%s)
  case $job in
    tests)
      $bin/unit_gpu 2>&1 > "$res_dir/unit_gpu.log"; log "unit_gpu: $(tail -1 "$res_dir/unit_gpu.log")"
      $bin/unit_sim --gtest_filter='*Solid*:*cuda*' > "$res_dir/unit_sim.log" 2>&1
      log "unit_sim (solid, cuda): $(grep -E 'PASSED|FAILED' "$res_dir/unit_sim.log" | tr '\n' ' ')"
      ;;
    leak)
      d=$res_dir/berea100_r0.5
      berea 0:100,0:100,0:100 0.5 "$d" --body-force 0.04 --relax-steps 1000 --flow-steps 50000 \
        --thermo-every 1000 --region-every 1000
      $bin/rockflow run "$d/scene.toml" --out "$d/run" --backend cuda > "$d/run.log" 2>&1
      log "leak run: exit $?, $(( $(date +%s) - start )) s; $(tail -1 "$d/run.log" | tr '\r' ' ' | tail -c 200)"
      rm -f "$d/particles.h5" "$d/run/final.h5" "$d/tiles.h5"
      ;;
    res)
      # One force per resolution, scaled as 1 / (rc per voxel)^2 so the pore velocities (and the
      # signal over the thermal noise of the flux) stay alike.
      for spec in $(for r in $RES; do echo berea:$r; done; for r in ${LEOPARD_RES-0.5}; do echo leopard:$r; done); do
        rock_name=${spec%%:*} r=${spec#*:}
        g=$(python3 -c "print(round(0.04 / $r ** 2, 4))")
        d=$res_dir/${rock_name}50_r$r
        $rock_name 0:50,0:50,0:50 "$r" "$d"
        sweep "$d" "$g"
        rm -f "$d/particles.h5" "$d/tiles.h5"
      done
      ;;
    darcy)
      for rock_name in $DARCY_ROCKS; do
        if [ "$rock_name" = berea ]; then r=$DARCY_RES_BEREA forces=$DARCY_FORCES_BEREA
        else r=$DARCY_RES_LEOPARD forces=$DARCY_FORCES_LEOPARD; fi
        d=$res_dir/${rock_name}50_darcy_r$r
        $rock_name 0:50,0:50,0:50 "$r" "$d"
        sweep "$d" "$forces"
        rm -f "$d/particles.h5" "$d/tiles.h5"
        pack
      done
      ;;
  esac
  log "job $job: $(( $(date +%s) - start )) s"
  pack
done
pack
