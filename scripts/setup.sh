#!/usr/bin/env bash
# Installs every build and test dependency of mesorock from Debian packages.
# Idempotent: packages already present are skipped, so a second run is fast.
# CUDA is not a Debian package here: it is used when /usr/local/cuda/bin/nvcc exists.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libhdf5-dev hdf5-tools libeigen3-dev
  libopenmpi-dev openmpi-bin
  libcli11-dev libtomlplusplus-dev libspdlog-dev libfmt-dev librandom123-dev
  nlohmann-json3-dev libtiff-dev zlib1g-dev libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-numpy python3-h5py python3-matplotlib
  clang libclang-rt-14-dev libomp-dev  # scripts/fuzz.sh: libFuzzer, ASan and UBSan runtimes
  clang-format                         # scripts/check_format.sh (CI)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
