#!/usr/bin/env bash
# Builds the CUDA targets here (nvcc, -arch=sm_90) and gathers what the GPU machine needs into
# .carry/gpu: rockflow, the test programs, and the shared libraries that machine lacks.
# The GPU machine (Ubuntu 24.04, CUDA 13) has no OpenVDB, toml++, Random123 or package access,
# so building here and carrying the binaries is the simplest path (DESIGN.md, GPU machine facts).
# Then run on the device:  bash scripts/gpu/device_run.sh [quick|full]
# BUILD_DIR=build reuses the main build folder when it already builds CUDA for sm_90 (the
# default configuration when nvcc is here): no second full build.
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=${BUILD_DIR:-build-gpu}
if [ "$dir" = build-gpu ]; then
  cmake -S . -B build-gpu -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESOROCK_BUILD_ROCKPREP=OFF \
    -DMESOROCK_ENABLE_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 >/dev/null
else
  grep -q "^MESOROCK_ENABLE_CUDA:BOOL=ON" "$dir/CMakeCache.txt" ||
    { echo "build_bundle.sh: $dir is not a CUDA build" >&2; exit 1; }
fi
cmake --build "$dir" --parallel "$(nproc)" --target rockflow unit_sim unit_gpu unit_mpi unit_lbm
rm -rf .carry/gpu && mkdir -p .carry/gpu/bin .carry/gpu/lib
cp "$dir/bin/rockflow" "$dir/bin/unit_sim" "$dir/bin/unit_gpu" "$dir/bin/unit_mpi" "$dir/bin/unit_lbm" .carry/gpu/bin/
# Only the libraries the GPU machine lacks (toml++). HDF5 is not carried: the machine's own
# libhdf5_serial.so.103 (1.10) has the same soname and brings its own dependency chain; likewise
# Open MPI's libmpi.so.40 (4.1.6 there, 4.1.4 here: the same ABI).
for lib in $(ldd "$dir/bin/rockflow" | awk '/tomlplusplus/ {print $3}'); do
  cp -L "$lib" .carry/gpu/lib/
done
# Side-by-side variants for benchmarks: VARIANTS="name:-DDEFINE ..." builds rockflow once more per
# variant with the extra CUDA definitions, comma-separated
# (e.g. VARIANTS="inplace:-DMESOROCK_NO_NEIGHBOUR_STASH,-DMESOROCK_NO_PACKED_NEIGHBOURS").
for spec in ${VARIANTS:-}; do
  name=${spec%%:*}
  flags=${spec#*:}
  flags=${flags//,/ }
  cmake -S . -B "build-gpu-$name" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMESOROCK_BUILD_ROCKPREP=OFF \
    -DMESOROCK_ENABLE_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 -DCMAKE_CUDA_FLAGS="$flags" >/dev/null
  cmake --build "build-gpu-$name" --parallel "$(nproc)" --target rockflow
  cp "build-gpu-$name/bin/rockflow" ".carry/gpu/bin/rockflow-$name"
done
# ROCKPREP=1: rockprep too (the main build's, which has OpenVDB), and the libraries of its chain
# that the GPU machine lacks, xz-packed (libopenvdb alone is 57 MB; 5 MB packed): real-rock
# crops are then packed there in seconds instead of carrying their particle files
# (scripts/gpu/rock_run.sh).
if [ -n "${ROCKPREP:-}" ]; then
  rp=${ROCKPREP_BUILD:-build}/bin/rockprep
  cp "$rp" .carry/gpu/bin/
  libs=$(ldd "$rp" | awk '/openvdb|tbb|blosc|Imath|boost|log4cplus|tiff|jbig|webp|Lerc|deflate|jpeg|snappy|tomlplusplus/ {print $3}')
  rm -rf /tmp/rockprep-libs && mkdir -p /tmp/rockprep-libs
  for lib in $libs; do cp -L "$lib" /tmp/rockprep-libs/; done
  tar cJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs .
fi
strip .carry/gpu/bin/*  # device code stays; host symbols are not needed there (64 MiB limit)
{ git rev-parse --short=12 HEAD; git diff --quiet HEAD || echo "+uncommitted changes"; } > .carry/gpu/COMMIT
du -sh .carry/gpu
