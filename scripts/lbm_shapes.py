#!/usr/bin/python3
"""Voxelised validation shapes for `rockflow lbm`, written as solid.h5 (sim/solid_grid.h):
a simple-cubic array of solid spheres (Zick & Homsy 1982) and a circular tube along x.

  /usr/bin/python3 scripts/lbm_shapes.py spheres --cell 32 --radius-fraction 0.3103 --out spheres32.h5
  /usr/bin/python3 scripts/lbm_shapes.py tube --radius 8 --out tube8.h5

A voxel is solid when its centre lies inside the sphere (outside the tube). The spheres'
radius-fraction 0.3103 = 9.93 / 32 gives a solid fraction near 0.123 (docs/lbm.md)."""
import argparse
import json
import sys

import h5py
import numpy as np


def spheres(cell, fraction):
    c = np.arange(cell) + 0.5 - cell / 2
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    return (np.sqrt(x * x + y * y + z * z) < fraction * cell).astype(np.uint8)


def tube(radius, length):
    cell = int(2 * radius) + 2
    c = np.arange(cell) + 0.5 - cell / 2
    z, y = np.meshgrid(c, c, indexing="ij")
    section = (np.sqrt(y * y + z * z) >= radius).astype(np.uint8)
    return np.repeat(section[:, :, None], length, axis=2)  # [z, y, x]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("shape", choices=["spheres", "tube"])
    p.add_argument("--cell", type=int, default=32, help="spheres: the periodic cell in voxels")
    p.add_argument("--radius-fraction", type=float, default=9.93 / 32)
    p.add_argument("--radius", type=float, default=8.0, help="tube: radius in voxels")
    p.add_argument("--length", type=int, default=2, help="tube: voxels along x")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    solid = spheres(a.cell, a.radius_fraction) if a.shape == "spheres" else tube(a.radius, a.length)
    try:
        with h5py.File(a.out, "w") as f:
            f.attrs["created_by"] = "scripts/lbm_shapes.py"
            f.attrs["provenance"] = json.dumps(vars(a))
            d = f.create_dataset("solid", data=solid)
            d.attrs["voxel_rc"] = np.ones(3)
            d.attrs["origin_rc"] = np.zeros(3)
            d.attrs["nm_per_rc"] = 0.0
    except OSError as e:
        sys.exit(f"lbm_shapes.py: {a.out}: {e}")
    print(f"{a.out}: {a.shape}, {solid.shape[::-1]} voxels (x y z), solid fraction "
          f"{solid.mean():.6f}")


if __name__ == "__main__":
    main()
