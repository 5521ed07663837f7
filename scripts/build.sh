#!/usr/bin/env bash
# Configures and builds mesorock into ./build (Release). Extra arguments go to cmake's configure
# step, e.g. `bash scripts/build.sh -DMESOROCK_ENABLE_CUDA=OFF`.
# CUDA is built when /usr/local/cuda/bin/nvcc exists; OpenVDB-based tools when the package is there.
set -euo pipefail
cd "$(dirname "$0")/.."
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
[ -f build/CMakeCache.txt ] && generator=()  # keep the generator of an existing build
# MESOROCK_WERROR=ON in the environment: warnings are errors (CI sets it).
werror=()
[ -n "${MESOROCK_WERROR:-}" ] && werror=(-DMESOROCK_WERROR="$MESOROCK_WERROR")
cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "${werror[@]}" "$@" >/dev/null
cmake --build build --parallel "$(nproc)"
echo "build: done (binaries in build/bin)"
