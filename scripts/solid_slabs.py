#!/usr/bin/env python3
"""Pore voxels and solid faces per pore voxel in slabs across a solid.h5 along x.

    python3 scripts/solid_slabs.py DIR/solid.h5 SLABS

How much wall a slab's pores have per pore volume (docs/permeability.md, "The block region at
no force"). Needs h5dump and h5ls (hdf5-tools); no numpy. Periodic neighbours on every axis, as
in rockprep's permeability box. The slabs split the voxels along x evenly (the count must divide
them).
"""
import os
import re
import subprocess
import sys
import tempfile


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    path, slabs = sys.argv[1], int(sys.argv[2])
    listing = subprocess.run(["h5ls", path], capture_output=True, text=True, check=True).stdout
    m = re.search(r"solid\s+Dataset \{(\d+), (\d+), (\d+)\}", listing)
    if not m:
        sys.exit(f"{path}: no /solid dataset of three dimensions")
    nz, ny, nx = (int(g) for g in m.groups())
    if slabs <= 0 or nx % slabs:
        sys.exit(f"{path}: {slabs} slabs do not split {nx} voxels along x evenly")
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "solid.bin")
        subprocess.run(["h5dump", "-d", "/solid", "-b", "LE", "-o", raw, path],
                       capture_output=True, check=True)
        solid = open(raw, "rb").read()
    if len(solid) != nx * ny * nz:
        sys.exit(f"{path}: /solid holds {len(solid)} bytes, not {nx * ny * nz}")
    width = nx // slabs
    pores, faces = [0] * slabs, [0] * slabs
    for k in range(nz):
        for j in range(ny):
            row = (k * ny + j) * nx
            up_y, down_y = (k * ny + (j + 1) % ny) * nx, (k * ny + (j - 1) % ny) * nx
            up_z, down_z = (((k + 1) % nz) * ny + j) * nx, (((k - 1) % nz) * ny + j) * nx
            for i in range(nx):
                if solid[row + i]:
                    continue
                s = i // width
                pores[s] += 1
                faces[s] += (solid[row + (i + 1) % nx] + solid[row + (i - 1) % nx] +
                             solid[up_y + i] + solid[down_y + i] + solid[up_z + i] +
                             solid[down_z + i])
    print("slab,first_voxel,last_voxel,pore_voxels,solid_faces,faces_per_pore_voxel")
    for s in range(slabs):
        per = faces[s] / pores[s] if pores[s] else float("nan")
        print(f"x{s},{s * width},{(s + 1) * width - 1},{pores[s]},{faces[s]},{per:.3f}")


if __name__ == "__main__":
    main()
