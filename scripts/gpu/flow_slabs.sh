#!/usr/bin/env bash
# Is the scene's slow fall of flow rate the compressible fluid's pressure settling along the flow
# axis? (docs/permeability.md, "The flow rate's slow fall"). In one call:
# a. the issue's Berea 100^3 crop at 0.5 rc per voxel, 15,000 steps, the box cut into 10 slabs
#    across x as regions: each slab's fluid count and flow rate in windows of 1,500 steps
#    (an incompressible steady flow carries the same flow rate through every slab);
# b. the crop halved along x (0:100,0:100,0:50), the same run: the box's flow rate by 1,000 steps
#    (pressure diffusion: a box half as long settles four times faster);
# c. a sweep of (a)'s scene at its force with a 15,000-step warm-up: k once the flow has settled.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/slabs; mkdir -p $W
add_slabs() {  # SCENE: 10 slab regions across x of the box
  python3 - "$1" <<'PY'
import re, sys
p = sys.argv[1]
s = open(p).read()
hi = [float(v) for v in re.search(r"hi = \[([^\]]*)\]", s).group(1).split(",")]
out = []
for k in range(10):
    out.append(f"[[output.regions]]\nname = \"slab{k}\"\nlo = [{hi[0] * k / 10}, 0.0, 0.0]\n"
               f"hi = [{hi[0] * (k + 1) / 10}, {hi[1]}, {hi[2]}]\nevery = 50\ntypes = [\"fluid\"]\n")
open(p, "w").write(s + "\n" + "\n".join(out))
PY
}
berea_prep 0:100,0:100,0:100 $W/A --seed 7 --rc-per-voxel 0.5 --flow-steps 15000 --tile-cache $W/cache
add_slabs $W/A/scene.toml
$B/rockflow run $W/A/scene.toml --backend cuda --out $W/a > $W/a.txt 2>&1
echo "== a. 100^3 at 0.5, 10 slabs rc=$?"; grep -E "done:" $W/a.txt | sed 's/; outputs in.*//'
cp $W/a/regions.csv $O/slabs_regions.csv; cp $W/a/thermo.csv $O/slabs_thermo.csv
window_table $W/a/regions.csv 1500
berea_prep 0:100,0:100,0:50 $W/B --seed 7 --rc-per-voxel 0.5 --flow-steps 15000 --tile-cache $W/cache
grep -E "watch it flow" $W/B.log
$B/rockflow run $W/B/scene.toml --backend cuda --out $W/b > $W/b.txt 2>&1
echo "== b. 100x100x50 at 0.5 rc=$?"; grep -E "done:|region " $W/b.txt | sed 's/; outputs in.*//'
cp $W/b/regions.csv $O/half_regions.csv
window_table $W/b/regions.csv 1000
$B/rockflow sweep $W/A/scene.toml --backend cuda --viscosity 6.111 --viscosity-error 0.041 \
  --forces 0.147 --warmup 15000 --block-steps 1000 --window 3 --measure-blocks 10 \
  --max-steps 40000 --out $W/c > $W/c.txt 2>&1
echo "== c. sweep after a 15,000-step warm-up rc=$?"; grep -E "k =" $W/c.txt
cp $W/c/sweep.json $O/long_sweep.json; cp $W/c/sweep_blocks.csv $O/long_sweep_blocks.csv
