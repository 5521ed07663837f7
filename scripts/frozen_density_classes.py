#!/usr/bin/env python3
"""Which of a rock scene's frozen particles need a density every step (docs/benchmarks.md, "Where
the rock target stands after this session"): each frozen particle's distance to the nearest pore
voxel of the scene's solid grid (the distance to the voxel's box, as SolidView::pore_within
measures it), sorted into three classes:

- within rd (0.75) of a pore voxel: a mobile particle may come within rd, so its density changes;
- between rd and rc: the passes visit it (its conservative force, phi) but its density is its
  static sum every step, since no mobile particle comes within rd while the bounce holds;
- farther than rc: buried (StepView::buried_part), never visited by a step.

    python3 scripts/frozen_density_classes.py SCENE_DIR [SCENE_DIR ...]

SCENE_DIR is a `rockprep run --layout permeability` output folder (solid.h5, particles.h5 with
type 0 the fluid). Needs numpy and h5py (scripts/setup.sh installs Debian's python3-h5py).
"""
import sys

import h5py
import numpy as np

RD, RC, MARGIN = 0.75, 1.0, 1.001


def nearest_pore_distance(points, solid, voxel, origin):
    """Distance from each point to the box of its nearest pore voxel (periodic grid)."""
    nz, ny, nx = solid.shape
    dims = np.array([nx, ny, nz])
    p = points - origin
    idx = np.floor(p / voxel).astype(int)
    reach = int(np.ceil(RC * MARGIN / voxel)) + 1
    best = np.full(len(p), np.inf)
    for dz in range(-reach, reach + 1):
        for dy in range(-reach, reach + 1):
            for dx in range(-reach, reach + 1):
                n = idx + np.array([dx, dy, dz])
                w = n % dims
                pore = ~solid[w[:, 2], w[:, 1], w[:, 0]]
                lo = n * voxel
                gap = np.maximum(np.maximum(lo - p, p - (lo + voxel)), 0)
                best = np.where(pore, np.minimum(best, (gap**2).sum(1)), best)
    return np.sqrt(best)


def main(folders):
    for folder in folders:
        grid = h5py.File(folder + "/solid.h5", "r")["solid"]
        voxel = float(grid.attrs["voxel_rc"][0])
        origin = np.asarray(grid.attrs["origin_rc"], dtype=float)
        solid = grid[...].astype(bool)  # z, y, x
        particles = h5py.File(folder + "/particles.h5", "r")["particles"]
        kind = particles["type"][...]
        frozen = particles["position"][...][kind != 0]
        d = nearest_pore_distance(frozen, solid, voxel, origin)
        near = int((d < RD * MARGIN).sum())
        shell = int(((d >= RD * MARGIN) & (d < RC * MARGIN)).sum())
        buried = len(d) - near - shell
        print(f"{folder}: {int((kind == 0).sum())} fluid, {len(d)} frozen: within rd {near}, "
              f"rd to rc {shell}, buried {buried}; of the visited frozen particles "
              f"{100 * shell / max(near + shell, 1):.1f}% need no density scan")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
