#!/usr/bin/env python3
"""What bounds a rock scene's fluid against a bulk liquid (docs/benchmarks.md, "The rock target
and the resolution"): per fluid particle, its fluid and wall neighbours within rc = 1; per wall
particle, its fluid neighbours; from these the pair visits per fluid particle and step.

A fluid-fluid pair is visited once for both particles (the half list); a fluid-wall pair once for
the fluid's sums and forces and once for the wall particle's density. A bulk liquid of density 6.5
visits (4 pi / 3) 6.5 / 2 = 13.6 pairs per particle and step.

    python3 scripts/neighbour_composition.py SCENE_DIR [SCENE_DIR ...]

SCENE_DIR is a `rockprep run --layout permeability` output folder (scene.toml, particles.h5 with
type 0 the fluid). Needs Python 3.11 (tomllib), numpy and h5py (scripts/setup.sh installs Debian's python3-h5py).
Samples 4,000 particles of each kind with a fixed seed.
"""
import sys
import tomllib

import h5py
import numpy as np

SAMPLES = 4000
BULK_VISITS = 4 * np.pi / 3 * 6.5 / 2


def box_of(scene_toml):
    with open(scene_toml, "rb") as f:
        box = tomllib.load(f)["box"]
    return np.array(box["lo"], dtype=float), np.array(box["hi"], dtype=float)


class CellList:
    """Particles binned in cells of at least rc = 1, periodic."""

    def __init__(self, positions, lo, hi):
        self.p, self.length = positions - lo, hi - lo
        self.n = np.maximum(np.floor(self.length).astype(int), 1)
        cell = np.minimum((self.p / (self.length / self.n)).astype(int), self.n - 1)
        self.cell = cell
        key = self.key(cell)
        self.order = np.argsort(key, kind="stable")
        keys = np.arange(self.n.prod())
        self.start = np.searchsorted(key[self.order], keys)
        self.end = np.searchsorted(key[self.order], keys, "right")

    def key(self, c):
        return (c[..., 0] * self.n[1] + c[..., 1]) * self.n[2] + c[..., 2]

    def neighbours(self, i):
        parts = []
        for shift in np.ndindex(3, 3, 3):
            k = self.key((self.cell[i] + np.array(shift) - 1) % self.n)
            parts.append(self.order[self.start[k] : self.end[k]])
        idx = np.concatenate(parts)
        idx = idx[idx != i]
        r = self.p[idx] - self.p[i]
        r -= self.length * np.round(r / self.length)
        return idx[(r * r).sum(1) < 1.0]


def report(folder):
    with h5py.File(folder + "/particles.h5", "r") as f:
        positions = f["particles/position"][:]
        types = f["particles/type"][:]
    cells = CellList(positions, *box_of(folder + "/scene.toml"))
    rng = np.random.default_rng(1)
    fluid, wall = np.flatnonzero(types == 0), np.flatnonzero(types != 0)
    if len(fluid) == 0 or len(wall) == 0:
        sys.exit(f"{folder}: needs fluid (type 0) and wall particles")
    near_fluid, near_wall = [], []
    for i in rng.choice(fluid, min(SAMPLES, len(fluid)), replace=False):
        t = types[cells.neighbours(i)]
        near_fluid.append((t == 0).sum())
        near_wall.append((t != 0).sum())
    near_fluid, near_wall = np.array(near_fluid), np.array(near_wall)
    wall_fluid = np.array(
        [(types[cells.neighbours(j)] == 0).sum() for j in rng.choice(wall, min(SAMPLES, len(wall)), replace=False)]
    )
    visits = near_fluid.mean() / 2 + near_wall.mean() + wall_fluid.mean() * len(wall) / len(fluid)
    print(
        f"{folder}: fluid {len(fluid)}, wall {len(wall)} ({(wall_fluid > 0).mean():.1%} with fluid within rc); "
        f"per fluid particle {near_fluid.mean():.2f} fluid and {near_wall.mean():.2f} wall neighbours, "
        f"{(near_wall > 0).mean():.1%} with a wall one; {visits:.1f} pair visits per fluid particle "
        f"against the bulk's {BULK_VISITS:.1f}: at most {BULK_VISITS / visits:.1%} of the bulk rate"
    )


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for folder in sys.argv[1:]:
        report(folder)
