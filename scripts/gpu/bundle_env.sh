# Sourced by the device scripts in scripts/gpu: unpacks the bundle that build_bundle.sh made in
# .carry/gpu, and sets B (its binaries) and O (the output folder, $OUT on the device).
# berea_prep CROP OUT [options]: rockprep's permeability scene of the Berea image in .carry/rock
# (never committed), the issue's spacing, on every core; its log in OUT.log.
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
export LD_LIBRARY_PATH=$PWD/.carry/gpu/lib:/tmp/rockprep-libs
mkdir -p .carry/gpu/bin && tar xJf .carry/gpu/bins.tar.xz -C .carry/gpu/bin
if [ -f .carry/gpu/rockprep-libs.tar.xz ]; then
  mkdir -p /tmp/rockprep-libs && tar xJf .carry/gpu/rockprep-libs.tar.xz -C /tmp/rockprep-libs
fi
B=$PWD/.carry/gpu/bin
O=${OUT:-/tmp/out}
mkdir -p "$O"
berea_prep() {
  local crop=$1 out=$2
  shift 2
  $B/rockprep run .carry/rock/berea_100_to_300.npz --labels true=pore,false=solid --crop "$crop" \
    --spacing 5.345,5.345,5.345 --unit um --layout permeability --threads "$(nproc)" "$@" \
    --out "$out" > "$out.log" 2>&1 || tail -3 "$out.log"
}
