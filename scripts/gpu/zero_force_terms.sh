#!/usr/bin/env bash
# Which part of the step makes a flux without a force (scripts/gpu/zero_force.sh)? rockprep's
# permeability scene of the issue's Berea 100^3 crop at RPV rc per voxel (default 0.85), g = 0,
# FLOW flow steps (default 6000), run with the wall model's Li2018 reflection (as written), the
# specular one, the solid grid's bounce off, the wall model off, and both off; the flow rate along
# x of the block and of its mirror image (a region added here) after the first 2000 flow steps,
# and their means over each 10 time units. SEED: the packing's seed (default 7); TILE_SEED: the
# tile sets' (default rockprep's, 1); VARIANTS: a subset of the five; SLICES=n adds n slabs across
# the box along x as regions, and prints each one's fluid count at the first and last sample.
set -uo pipefail
. "$(dirname "$0")/bundle_env.sh"
W=/tmp/zt; mkdir -p $W
berea_prep 0:100,0:100,0:100 $W/S --seed ${SEED:-7} --rc-per-voxel ${RPV:-0.85} \
  --flow-steps ${FLOW:-6000} --tile-seed ${TILE_SEED:-1} --tile-cache $W/cache
python3 - $W/S/scene.toml <<'PY'
import os, re, sys
p = sys.argv[1]
s = open(p).read()
s = re.sub(r'^body_force = \[[^]]*\]', 'body_force = [0.0, 0.0, 0.0]', s, flags=re.M)
lo = re.search(r'name = "block"\nlo = \[([^]]*)\]\nhi = \[([^]]*)\]', s)
hi = [float(x) for x in lo.group(2).split(',')]
s += f'\n[[output.regions]]\nname = "mirror"\nlo = [{hi[0]}, 0.0, 0.0]\nhi = [{2 * hi[0]}, {hi[1]}, {hi[2]}]\nevery = 50\ntypes = ["fluid"]\n'
slices = int(os.environ.get('SLICES', '0'))  # that many slabs across the box along x, x0, x1, ...
for k in range(slices):
    a, b = 2 * hi[0] * k / slices, 2 * hi[0] * (k + 1) / slices
    s += f'\n[[output.regions]]\nname = "x{k}"\nlo = [{a}, 0.0, 0.0]\nhi = [{b}, {hi[1]}, {hi[2]}]\nevery = 50\ntypes = ["fluid"]\n'
open(p.replace('scene.toml', 'base.toml'), 'w').write(s)
# without the bounce fluid gets into the grains: counted, not stopped
unbounced = 'file = "solid.h5"\nbounce = false\nstop_depth = 4.0\nstop_count = 1000000000'
variants = {
    'li2018': s,
    'specular': s.replace('model = "li2018"', 'model = "li2018"\nreflection = "specular"'),
    'no_bounce': s.replace('file = "solid.h5"', unbounced),
    'no_wall_model': re.sub(r'^\[walls\].*?(?=^\[)', '[walls]\nmodel = "none"\n\n', s,
                            flags=re.S | re.M),
}
variants['neither'] = variants['no_wall_model'].replace('file = "solid.h5"', unbounced)
for k, v in variants.items():
    open(p.replace('scene.toml', k + '.toml'), 'w').write(v)
PY
for v in ${VARIANTS:-li2018 specular no_bounce no_wall_model neither}; do
  $B/rockflow run $W/S/$v.toml --backend cuda --out $W/run > $W/run.txt 2>&1 || { echo "$v: $(tail -1 $W/run.txt)"; continue; }
  cp $W/run/regions.csv $O/regions_terms_$v.csv
  python3 - $W/run/regions.csv $W/run/summary.json $v <<'PY'
import csv, json, math, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith('#'))
        if r['stage'] == 'flow' and r['type'] == 'fluid']
start = int(rows[0]['step']) + 2000
out = []
for region in ('block', 'mirror'):
    q = [float(r['flow_rate_x']) for r in rows if r['region'] == region and int(r['step']) >= start]
    b = [sum(q[k:k + 10]) / 10 for k in range(0, len(q) - 9, 10)]
    m = sum(b) / len(b)
    e = math.sqrt(sum((x - m) ** 2 for x in b) / (len(b) - 1) / len(b))
    out.append(f"{region} {m:.2f} +- {e:.2f}")
    q = [float(r['flow_rate_x']) for r in rows if r['region'] == region]
    out.append('every 10 time units ' + ' '.join(
        f"{sum(q[k:k + 20]) / 20:.1f}" for k in range(0, len(q) - 19, 20)))
slices = sorted({r['region'] for r in rows if r['region'][0] == 'x'}, key=lambda n: int(n[1:]))
if slices:  # each slab's fluid count at the flow stage's first sample and last, and its mean Q
    def at(name, row):
        return [r for r in rows if r['region'] == name][row]
    out.append('slabs (count first -> last, mean Q): ' + ', '.join(
        f"{n} {float(at(n, 0)['count']):.0f} -> {float(at(n, -1)['count']):.0f}"
        f" ({sum(float(r['flow_rate_x']) for r in rows if r['region'] == n) / len([r for r in rows if r['region'] == n]):.1f})"
        for n in slices))
s = json.load(open(sys.argv[2]))
print(f"{sys.argv[3]}: flow rate x, g = 0: {'; '.join(out)}; T {s['final_temperature']:.4f}; "
      f"solid {s.get('solid', {}).get('invariant')}; corrections {s.get('walls', {}).get('corrections')}")
PY
done
