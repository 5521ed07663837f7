# Sourced by the device scripts in scripts/gpu: unpacks the bundle that build_bundle.sh made in
# .carry/gpu, and sets B (its binaries) and O (the output folder, $OUT on the device).
# berea_prep CROP OUT [options]: rockprep's permeability scene of the Berea image in .carry/rock
# (never committed), the issue's spacing, on every core; its log in OUT.log.
# window_table REGIONS.CSV STEPS: each region's fluid count and flow rate along x in rockflow run's
# regions.csv, flow stage only, averaged over windows of STEPS steps (a last window with fewer
# than half the samples of a full one left out).
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
window_table() {
  python3 - "$1" "$2" <<'PY'
import csv, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith('#'))
        if r['stage'] == 'flow']
win = int(sys.argv[2])
first = int(rows[0]['step'])
for what in ('count', 'flow_rate_x'):
    print(f"  {what} by {win} steps")
    for g in dict.fromkeys(r['region'] for r in rows):
        w = {}
        for r in rows:
            if r['region'] == g:
                w.setdefault((int(r['step']) - first) // win, []).append(float(r[what]))
        full = max(len(v) for v in w.values())
        print(f"  {g:>6}:", " ".join(f"{sum(v) / len(v):8.1f}" for k, v in sorted(w.items())
                                     if 2 * len(v) >= full))
PY
}
