#!/usr/bin/env python3
"""Real rock against a continuum reference (docs/validation.md, "Real rock").

The chain a user runs, on a crop of a real micro-CT image from ../shared/data/rocks:
  rockprep run IMAGE --layout permeability   -> particles, scene, solid.h5 (the voxels)
  rockflow lbm solid.h5                      -> k of Stokes flow on the identical voxels (LBM)
  rockflow sweep scene.toml                  -> k of the mDPD fluid (Darcy fit over the forces)
and judges, each with its reference, source and tolerance:
  - the leak invariant: no fluid particle inside a solid voxel at any block of any point
    (sweep.json), and none deeper than 0.52 rc (the flat-wall no-penetration bound);
  - k(mDPD) against k(LBM) on the same voxels, within --tolerance (relative);
  - with three forces or more: the Darcy fit's chi^2 below its 99% point and the line's
    intercept within 2 sigma of zero (Darcy-linear, no drift).
Exit 0 when every quantity passes, 1 when one fails, 2 on a usage or tool error, 77 (ctest's
skip code) when the image folder is absent.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time

IMAGES = {
    # name: file, --labels, --spacing, unit (../shared/data/rocks/README.md)
    "berea": ("berea_100_to_300.npz", "true=pore,false=solid", "5.345,5.345,5.345", "um"),
    "leopard": ("image_Leopard_slice100.npy", "1=pore,0=solid", "2.25,2.25,2.25", "um"),
}


def run(cmd, log):
    with open(log, "w") as f:
        f.write(" ".join(cmd) + "\n")
        f.flush()
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        tail = open(log).read().splitlines()[-5:]
        raise RuntimeError(f"{cmd[0]} {cmd[1]} failed (exit {r.returncode}); {log}:\n" + "\n".join(tail))


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.abspath(os.path.join(here, "..", ".."))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rockprep", default=os.path.join(root, "build", "bin", "rockprep"))
    p.add_argument("--rockflow", default=os.path.join(root, "build", "bin", "rockflow"))
    p.add_argument("--rocks", default=os.path.join(root, "..", "shared", "data", "rocks"))
    p.add_argument("--image", default="berea", choices=sorted(IMAGES))
    # The CI size: a 16^3 Berea crop that percolates along x (6,640 particles at 0.5 rc per
    # voxel, about 2 minutes on two cores). docs/validation.md, "Real rock", has the GPU sizes.
    p.add_argument("--crop", default="40:56,40:56,40:56", help="Z0:Z1,Y0:Y1,X0:X1")
    p.add_argument("--rc-per-voxel", default="0.5")
    p.add_argument("--forces", default="0.16")
    # At the CI size one point's flux carries about 8% of thermal noise (measured: -9.9% +- 7.7%
    # against the LBM on 2026-12-02): 25% is three of its standard errors. The GPU sizes agree
    # within 4% (docs/validation.md).
    p.add_argument("--tolerance", type=float, default=0.25,
                   help="relative tolerance of k(mDPD) against k(LBM)")
    p.add_argument("--tiles", default="", help="tile database (built small when missing)")
    p.add_argument("--backend", default="cpu")
    p.add_argument("--threads", default="1")
    # The viscosity of the fluid (A = -40, B = 25, gamma = 4.5, rd = 0.75, n = 6.5, dt = 0.01)
    # from the full reverse-Poiseuille calibration on the GPU (docs/permeability.md): the small
    # and tiny calibrations are biased low at this density (5.30 +- 0.20 for the small one).
    p.add_argument("--sweep-args", default="--warmup 1000 --block-steps 1000 --window 2 "
                   "--measure-blocks 8 --viscosity 6.111 --viscosity-error 0.041",
                   help="extra rockflow sweep options")
    # The converged reference: the ladder refine 1, 2, 3 extrapolated (docs/lbm.md). On this crop
    # it gives 5242 mD, and 1-4 gives 5277 +- 35 mD (2026-12-08, CPU); refine 2 alone read 5927,
    # 12% high, and hid the particle model's bias (issue 52).
    p.add_argument("--lbm-args", default="--refine 1,2,3 --backend cpu",
                   help="extra rockflow lbm options")
    p.add_argument("--out", default="out/real_rock")
    a = p.parse_args()

    file, labels, spacing, unit = IMAGES[a.image]
    image = os.path.join(a.rocks, file)
    if not os.path.isfile(image):
        if os.environ.get("CI") == "true":  # CI must check real rock, never skip it silently
            print(f"real_rock: error: {image} is absent in CI (../shared/data/rocks)")
            return 2
        print(f"real_rock: SKIP: {image} is absent (../shared/data/rocks holds the real images)")
        return 77
    os.makedirs(a.out, exist_ok=True)
    for old in ("setup", "lbm", "sweep"):  # a re-run starts clean (the tiles are kept)
        shutil.rmtree(os.path.join(a.out, old), ignore_errors=True)
    t0 = time.time()
    try:
        tiles = a.tiles or os.path.join(a.out, "tiles.h5")
        if not a.tiles and not os.path.isfile(tiles):
            # Small tile sets (seconds): enough for a CI-sized check of the chain.
            edge = f"{a.rc_per_voxel},{a.rc_per_voxel},{a.rc_per_voxel}"
            for role in ("wall", "fluid"):
                run([a.rockprep, "tiles", "build", tiles, "--role", role, "--voxel-rc", edge,
                     "--variants", "500", "--box-edge", "4", "--relax-steps", "100",
                     "--equilibrate-steps", "1000", "--threads", a.threads, "--quiet"],
                    os.path.join(a.out, f"tiles_{role}.log"))
        setup = os.path.join(a.out, "setup")
        run([a.rockprep, "run", image, "--labels", labels, "--spacing", spacing, "--unit", unit,
             "--crop", a.crop, "--rc-per-voxel", a.rc_per_voxel, "--layout", "permeability",
             "--tiles", tiles, "--threads", a.threads, "--out", setup],
            os.path.join(a.out, "rockprep.log"))
        run([a.rockflow, "lbm", os.path.join(setup, "solid.h5"), "--out",
             os.path.join(a.out, "lbm"), "--threads", a.threads] + a.lbm_args.split(),
            os.path.join(a.out, "lbm.log"))
        run([a.rockflow, "sweep", os.path.join(setup, "scene.toml"), "--out",
             os.path.join(a.out, "sweep"), "--forces", a.forces, "--backend", a.backend,
             "--threads", a.threads] + a.sweep_args.split(),
            os.path.join(a.out, "sweep.log"))
    except RuntimeError as e:
        print(f"real_rock: error: {e}")
        return 2
    lbm = json.load(open(os.path.join(a.out, "lbm", "lbm.json")))
    sweep = json.load(open(os.path.join(a.out, "sweep", "sweep.json")))

    rows = []  # name, measured, error, reference, tolerance, source, pass

    def judge(name, measured, error, reference, tolerance, source, ok):
        rows.append((name, measured, error, reference, tolerance, source, ok))

    inv = sweep["solid"]["invariant"]
    judge("fluid particles inside solid voxels, most at any block", inv["inside_max"], 0, 0, 0,
          "the solid grid's bounce: none ever (docs/walls.md)", inv["inside_max"] == 0)
    judge("deepest fluid particle inside the solid, rc", inv["max_depth_rc"], 0, 0.52, 0,
          "at most 0.52 rc, the flat-wall no-penetration bound (docs/validation.md)",
          inv["max_depth_rc"] <= 0.52)
    k_lbm = lbm["result"]["permeability"]["rc2"]
    k_md = sweep["fits"]["darcy"]["permeability"]["rc2"]
    k_err = sweep["fits"]["darcy"]["permeability"]["rc2_error"]
    judge("k(mDPD) / k(LBM) - 1", k_md / k_lbm - 1, k_err / k_lbm, 0, a.tolerance,
          f"rockflow lbm on the same voxels: k = {k_lbm:.5g} rc^2 "
          f"({lbm['result']['permeability'].get('mD', float('nan')):.4g} mD); "
          f"tolerance {a.tolerance:.0%}",
          abs(k_md / k_lbm - 1) <= a.tolerance)
    lr = lbm["result"]
    judge("LBM reference converged: ladder extrapolated and asymptotic", lr.get("order") or 0, 0,
          1, 0, f"rockflow lbm's ladder ({lr.get('extrapolation', 'one lattice')}); k_inf error "
          f"{(lr.get('permeability_error') or {}).get('rc2', float('nan')) / k_lbm:.2%}",
          bool(lr.get("extrapolated")) and bool(lr.get("asymptotic")))
    points = sweep["points"]
    for i, pt in enumerate(points):
        judge(f"point {i + 1} (g = {pt['force_g']}): steady, no drift", pt["drift"],
              pt["drift_error"], 0, 0, "the sweep's steady-state test (a trend beyond t_99 fails)",
              bool(pt["steady"]))
    if len(points) >= 3:
        d = sweep["fits"]["darcy"]
        judge("Darcy fit chi^2", d["chi2"], 0, d["chi2_99"], 0,
              f"below its 99% point for {d['dof']} dof", d["chi2"] <= d["chi2_99"])
        line = sweep["fits"]["line"]
        judge("line intercept q(0) / its error", line["intercept"] / line["intercept_error"], 0, 0,
              2, "within 2 sigma of zero (Darcy's law through the origin)",
              abs(line["intercept"]) <= 2 * line["intercept_error"])

    print(f"real_rock: {a.image} crop {a.crop} at {a.rc_per_voxel} rc per voxel, "
          f"forces {a.forces}, backend {a.backend}: {time.time() - t0:.0f} s")
    print(f"  k(mDPD) = {k_md:.5g} +- {k_err:.2g} rc^2, k(LBM) = {k_lbm:.5g} rc^2 "
          f"(porosity {lbm['result']['porosity']:.4f}); outputs in {a.out}")
    ok_all = True
    for name, measured, error, reference, tolerance, source, ok in rows:
        ok_all = ok_all and ok
        print(f"  {'PASS' if ok else 'FAIL'}  {name}: {measured:.4g}"
              f"{f' +- {error:.2g}' if error else ''} (reference {reference:g}"
              f"{f' +- {tolerance:g}' if tolerance else ''}; {source})")
    json.dump({"image": a.image, "crop": a.crop, "rc_per_voxel": a.rc_per_voxel,
               "forces": a.forces, "backend": a.backend, "k_mdpd_rc2": k_md,
               "k_mdpd_rc2_error": k_err, "k_lbm_rc2": k_lbm,
               "checks": [dict(zip(("name", "measured", "error", "reference", "tolerance",
                                    "source", "pass"), r)) for r in rows], "pass": ok_all},
              open(os.path.join(a.out, "real_rock.json"), "w"), indent=2)
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
