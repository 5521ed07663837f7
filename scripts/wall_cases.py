#!/usr/bin/env python3
"""Synthetic voxel walls through the user's path, against a continuum reference (issue 52, item 2).

For each synthetic geometry (a boolean image, True = pore, periodic in y and z as is; flow
along x, the axis rockprep's permeability layout mirrors) and each rc per voxel:

  rockprep run IMG.npy --labels true=pore,false=solid --layout permeability --rc-per-voxel R
  rockflow sweep S/scene.toml --forces F --viscosity 6.111 --viscosity-error 0.041 --backend B
  rockflow lbm S/solid.h5 --refine r                      (r = 1, 2, 3[, 4]: the ladder)

and compares k(mDPD) with the reference of the same voxels:
  slit   grid-aligned, gap h voxels in a period H:   exact (h/H) h^2 / 12
  duct   square, a x a voxels in a cell Ly x Lz:     exact series (a^2 / (Ly Lz)) a^2 c_sq
  stair  a slit whose walls step one voxel in z per s voxels in y (invariant along x)
  tube   a voxelised circle of diameter D voxels
  spheres a voxelised simple-cubic array of solid spheres
(all in rc^2 through (rc per voxel)^2). Every case also gets the LBM ladder k_inf (a fit
k(r) = k_inf + C1/r + C2/r^2 through the last three rungs, error = the change from the previous
three), and the cases invariant along x a second continuum value from a 2-D Poisson solve of the
cross-section refined 4..32 times (needs numpy; the same fit). For slit and duct it gives the
no-slip offset delta that makes the exact value of the aperture h - 2 delta equal the measured k,
and for every case the fluid's density in the pore voxels (N_fluid / pore volume) against the
nominal n_f.

Outputs: OUT/CASE_rR/ (image.npy, prep/, sweep/, lbm_r*/, logs), OUT/wall_cases.json (written
after every case), a table on stdout. Exit 0 when every case ran, 1 when one failed (the others
still run), 2 on a usage error.
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

try:
    import numpy as np  # only for the 2-D Poisson cross-check
except ImportError:  # the GPU machine may lack it: the rest does not need it
    np = None

CASES = ("slit", "stair", "duct", "tube", "spheres")

# Pore sizes in voxels per --size. tiny: seconds to a few minutes a case on 2 CPU cores at
# 1 rc per voxel (proves the pipeline); small: minutes a case on the CPU; gpu: pores 16-20
# voxels across, for the GPU machine.
SIZES = {
    "tiny": {"slit": 4, "stair": 4, "duct": 4, "tube": 6, "spheres": (6, 2.0)},
    "small": {"slit": 6, "stair": 6, "duct": 6, "tube": 8, "spheres": (8, 2.5)},
    "gpu": {"slit": 16, "stair": 16, "duct": 16, "tube": 20, "spheres": (20, 6.5)},
}


class CaseError(RuntimeError):
    pass


# ---------------------------------------------------------------------------------- geometry

def write_npy_bool(path, pore, shape):
    """A C-ordered bool .npy of shape (nz, ny, nx) from pore(z, y, x), without numpy."""
    nz, ny, nx = shape
    data = bytearray(nz * ny * nx)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                data[i] = 1 if pore(z, y, x) else 0
                i += 1
    header = "{'descr': '|b1', 'fortran_order': False, 'shape': (%d, %d, %d), }" % shape
    pad = 64 - (10 + len(header) + 1) % 64
    header = header + " " * pad + "\n"
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode("latin1"))
        f.write(bytes(data))
    return data


def make_geometry(case, size, rpv, step, pore_vox=None, width_rc=4.0):
    """The image of a case: (shape zyx, pore(z, y, x), description dict). pore_vox overrides the
    size's pore (h, a, D in voxels; spheres: the cell L, the radius scaled with it)."""
    p = SIZES[size][case]
    if pore_vox:
        p = (pore_vox, p[1] * pore_vox / p[0]) if case == "spheres" else pore_vox
    # Solid between the periodic copies: at least 1.5 rc (so no fluid sees the next copy's
    # fluid and each wall holds rockprep's 1 rc of wall particles) and 2 voxels.
    t = max(2, math.ceil(1.5 / rpv - 1e-9))
    nx = max(4, math.ceil(4.0 / rpv - 1e-9))  # 8 rc or more along x once mirrored
    lo = t // 2
    if case == "slit":
        h = p
        H = h + t
        ny = max(4, math.ceil(width_rc / rpv - 1e-9))  # the slit's free width (y)
        return (H, ny, nx), (lambda z, y, x: lo <= z < lo + h), \
            {"h_vox": h, "H_vox": H, "solid_vox": t}
    if case == "stair":
        h, s = p, step
        H = h + t
        Ly = s * H  # the wall rises one period H over Ly: periodic in y and z
        return (H, Ly, nx), (lambda z, y, x: lo <= (z - y // s) % H < lo + h), \
            {"h_vox": h, "H_vox": H, "step_vox": s, "Ly_vox": Ly, "solid_vox": t,
             "angle_deg": math.degrees(math.atan(1.0 / s)),
             "perpendicular_gap_vox": h * math.cos(math.atan(1.0 / s))}
    if case == "duct":
        a = p
        L = a + t
        return (L, L, nx), (lambda z, y, x: lo <= z < lo + a and lo <= y < lo + a), \
            {"a_vox": a, "cell_vox": L, "solid_vox": t}
    if case == "tube":
        D = p
        L = D + t
        c = L / 2.0
        r2 = (D / 2.0) ** 2
        return (L, L, nx), (lambda z, y, x: (y + 0.5 - c) ** 2 + (z + 0.5 - c) ** 2 < r2), \
            {"D_vox": D, "cell_vox": L, "solid_vox": t}
    if case == "spheres":
        L, rs = p
        c = L / 2.0
        r2 = rs * rs
        return (L, L, L), \
            (lambda z, y, x: (x + 0.5 - c) ** 2 + (y + 0.5 - c) ** 2 + (z + 0.5 - c) ** 2 >= r2), \
            {"cell_vox": L, "radius_vox": rs, "solid_fraction_nominal": 4 / 3 * math.pi * rs ** 3 / L ** 3}
    raise CaseError(f"unknown case {case}")


# -------------------------------------------------------------------------- exact references

def square_duct_coefficient(terms=200):
    """k_pore / a^2 of a square duct: (1/12) (1 - 192/pi^5 sum_{n odd} tanh(n pi / 2) / n^5)."""
    s = sum(math.tanh(n * math.pi / 2) / n ** 5 for n in range(1, 2 * terms, 2))
    return (1 - 192 / math.pi ** 5 * s) / 12


def exact_k_vox2(case, geo):
    """Exact continuum k (voxel^2) of the voxel image, with walls on the voxel faces; None if unknown."""
    if case == "slit":
        h, H = geo["h_vox"], geo["H_vox"]
        return h / H * h * h / 12
    if case == "duct":
        a, L = geo["a_vox"], geo["cell_vox"]
        return a * a / (L * L) * a * a * square_duct_coefficient()
    return None


def no_slip_offset(case, geo, rpv, k_rc2, k_err_rc2):
    """delta (rc) such that the exact k of aperture h - 2 delta equals k; + = inside the pore."""
    if k_rc2 is None or not k_rc2 > 0:
        return None, None
    if case == "slit":
        h, H = geo["h_vox"] * rpv, geo["H_vox"] * rpv
        heff = (12 * H * k_rc2) ** (1 / 3)  # k = heff^3 / (12 H)
        return (h - heff) / 2, heff / 6 * k_err_rc2 / k_rc2
    if case == "duct":
        a, L = geo["a_vox"] * rpv, geo["cell_vox"] * rpv
        aeff = (k_rc2 * L * L / square_duct_coefficient()) ** 0.25  # k = aeff^4 c / L^2
        return (a - aeff) / 2, aeff / 8 * k_err_rc2 / k_rc2
    return None, None


# ------------------------------------------------------------------- the refinement ladder

def ladder_fit(rs, ks):
    """k(r) = k_inf + C1/r + C2/r^2 through the last three rungs; the error is the change from
    the three before (with only three rungs: from the first-order fit of the last two).
    Kept as one function so that rockflow lbm's own ladder can replace it."""
    def three(r3, k3):
        # Solve [1, 1/r, 1/r^2] (k_inf, C1, C2) = k for three rungs (Cramer's rule).
        m = [[1.0, 1.0 / r, 1.0 / r ** 2] for r in r3]

        def det(a):
            return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                    - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                    + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
        d = det(m)
        sol = []
        for c in range(3):
            mc = [row[:] for row in m]
            for i in range(3):
                mc[i][c] = k3[i]
            sol.append(det(mc) / d)
        return sol

    if len(rs) < 3:
        raise CaseError(f"the ladder needs three rungs or more, got {rs}")
    k_inf, c1, c2 = three(rs[-3:], ks[-3:])
    if len(rs) >= 4:
        k_prev = three(rs[-4:-1], ks[-4:-1])[0]
        err, err_from = abs(k_inf - k_prev), "change from the previous three rungs"
    else:
        r1, r2 = rs[-2], rs[-1]  # k = k_inf + C / r through the last two
        k_first = (r2 * ks[-1] - r1 * ks[-2]) / (r2 - r1)
        err, err_from = abs(k_inf - k_first), "change from the first-order fit of the last two rungs"
    ratios = [(ks[i] - ks[i - 1]) / (ks[i + 1] - ks[i]) if ks[i + 1] != ks[i] else None
              for i in range(1, len(ks) - 1)]
    return {"k_inf": k_inf, "error": err, "error_from": err_from, "C1": c1, "C2": c2,
            "rungs": [{"r": r, "k": k} for r, k in zip(rs, ks)],
            "successive_change_ratios": ratios}


def lbm_ladder(a, solid_h5, refines, case_dir):
    """rockflow lbm at each refine; returns ladder_fit of k in voxel^2 (the image's voxels)."""
    ks = []
    for r in refines:
        d = os.path.join(case_dir, f"lbm_r{r}")
        if not (a.reuse and os.path.isfile(os.path.join(d, "lbm.json"))):
            run_tool([os.path.join(a.bin, "rockflow"), "lbm", solid_h5, "--out", d, "--refine",
                      str(r), "--tau", str(a.lbm_tau), "--threads", str(a.threads),
                      "--tolerance", str(a.lbm_tolerance)], os.path.join(case_dir, f"lbm_r{r}.log"))
        res = json.load(open(os.path.join(d, "lbm.json")))["result"]
        if not res.get("converged", False):
            raise CaseError(f"rockflow lbm --refine {r} did not converge ({d}/lbm.json)")
        ks.append(res["permeability"]["voxel2"])
    return ladder_fit(list(refines), ks)


def poisson_ladder(cross, periods=(4, 8, 16, 32), tol=1e-10):
    """Continuum k (voxel^2) of flow along x through the 2-D cross-section cross[z][y] (True =
    pore), periodic, no slip on the voxel faces: -lap u = 1 (mu = G = 1) on each voxel split into
    n x n cells (cell-centred, the wall half a cell beyond the last pore cell), by conjugate
    gradients; k(n) = mean u over all cells; the same ladder fit as the LBM. None without numpy."""
    if np is None:
        return None
    base = np.array(cross, dtype=bool)
    ks = []
    for n in periods:
        m = np.kron(base, np.ones((n, n), dtype=bool))
        dx = 1.0 / n
        nb = sum((~np.roll(m, s, ax)).astype(float) for ax in (0, 1) for s in (1, -1))

        def op(u):
            # -lap u on the pore cells. u is stored as 0 in the solid; a solid neighbour's ghost
            # value is -u (zero on the face between), which adds nb u for nb solid neighbours.
            lap = sum(np.roll(u, s, ax) for ax in (0, 1) for s in (1, -1)) - 4 * u
            return np.where(m, (nb * u - lap) / dx ** 2, 0.0)
        b = m.astype(float)
        u = np.zeros_like(b)
        r = b - op(u)
        p = r.copy()
        rr = float((r * r).sum())
        b2 = float((b * b).sum())
        for _ in range(20 * max(m.shape)):
            ap = op(p)
            alpha = rr / float((p * ap).sum())
            u += alpha * p
            r -= alpha * ap
            rr_new = float((r * r).sum())
            if rr_new < tol * tol * b2:
                break
            p = r + (rr_new / rr) * p
            rr = rr_new
        else:
            raise CaseError(f"2-D Poisson solve at {n} cells per voxel did not converge")
        ks.append(float(u.sum()) / u.size)
    return ladder_fit(list(periods), ks)


# ----------------------------------------------------------------------------------- tools

def run_tool(cmd, log):
    with open(log, "w") as f:
        f.write(" ".join(cmd) + "\n")
        f.flush()
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        tail = [l for l in open(log).read().replace("\r", "\n").splitlines() if l.strip()][-6:]
        raise CaseError(f"{os.path.basename(cmd[0])} {cmd[1]} failed (exit {r.returncode}); "
                        f"{log}:\n    " + "\n    ".join(tail))


def suggested_forces(prep_log):
    m = re.findall(r"--forces ([0-9.eE+-]+(?:,[0-9.eE+-]+)*)", open(prep_log).read())
    if not m:
        raise CaseError(f"no suggested forces in {prep_log}")
    return [float(v) for v in m[-1].split(",")]


def run_case(a, case, rpv):
    pv = a.pore_vox or (round(a.pore_rc / rpv) if a.pore_rc else None)
    name = f"{case}_r{rpv:g}" + (f"_p{pv}" if pv else "")
    d = os.path.join(a.out, name)
    os.makedirs(d, exist_ok=True)
    shape, pore, geo = make_geometry(case, a.size, rpv, a.step, pv, a.width_rc)
    img = os.path.join(d, "image.npy")
    data = write_npy_bool(img, pore, shape)
    nz, ny, nx = shape
    pore_vox = sum(data)
    rec = {"case": case, "name": name, "size": a.size, "rc_per_voxel": rpv,
           "shape_zyx": list(shape), "geometry": geo, "pore_voxels_block": pore_vox,
           "porosity_image": pore_vox / len(data)}
    t0 = time.time()

    # 1. rockprep: the user's path.
    prep = os.path.join(d, "prep")
    prep_log = os.path.join(d, "rockprep.log")
    if not (a.reuse and os.path.isfile(os.path.join(prep, "scene.toml"))):
        shutil.rmtree(prep, ignore_errors=True)
        cmd = [os.path.join(a.bin, "rockprep"), "run", img, "--labels", "true=pore,false=solid",
               "--layout", "permeability", "--rc-per-voxel", f"{rpv:g}", "--seed", str(a.seed),
               "--threads", str(a.threads), "--out", prep]
        if a.tiles:
            cmd += ["--tiles", a.tiles]
        if a.tile_cache:
            cmd += ["--tile-cache", a.tile_cache]
        cmd += a.rockprep_args.split()
        run_tool(cmd, prep_log)
    runj = json.load(open(os.path.join(prep, "run.json")))
    sugg = suggested_forces(prep_log)
    if a.forces == "top":
        forces = [max(sugg)]
    elif a.forces == "suggested":
        forces = sorted(sugg)
    else:
        forces = [float(v) for v in a.forces.split(",")]
    rec["rockprep"] = {"suggested_forces": sugg, "pore_sizes": runj.get("pore_sizes"),
                       "particles": runj["particles"]["by_type"], "seed": a.seed,
                       "warnings": runj.get("warnings", [])}
    bl, bh = runj["layout"]["box_lo"], runj["layout"]["box_hi"]
    box_volume = (bh[0] - bl[0]) * (bh[1] - bl[1]) * (bh[2] - bl[2])

    # 2. rockflow sweep: the mDPD permeability.
    sw = os.path.join(d, "sweep")
    if not (a.reuse and os.path.isfile(os.path.join(sw, "sweep.json"))):
        shutil.rmtree(sw, ignore_errors=True)
        cmd = [os.path.join(a.bin, "rockflow"), "sweep", os.path.join(prep, "scene.toml"),
               "--out", sw, "--forces", ",".join(f"{g:g}" for g in forces),
               "--viscosity", str(a.viscosity), "--viscosity-error", str(a.viscosity_error),
               "--backend", a.backend, "--threads", str(a.threads)] + a.sweep_args.split()
        run_tool(cmd, os.path.join(d, "sweep.log"))
    s = json.load(open(os.path.join(sw, "sweep.json")))
    darcy = s["fits"]["darcy"]["permeability"]
    k, k_err = darcy["rc2"], darcy["rc2_error"]
    pts = s["points"]
    # The flux's own error (the points' J errors through the fit, without the viscosity's).
    rel_mu = a.viscosity_error / a.viscosity
    k_stat = k * math.sqrt(max(0.0, (k_err / k) ** 2 - rel_mu ** 2)) if k > 0 else None
    n_nom = s["fluid_density"]
    pore_volume = s["solid"]["porosity"] * box_volume
    n_pore = s["fluid_particles"] / pore_volume
    rec["mdpd"] = {
        "k_rc2": k, "k_rc2_error": k_err, "k_rc2_error_flux_only": k_stat,
        "forces": forces, "viscosity": [a.viscosity, a.viscosity_error],
        "points": [{"g": p["force_g"], "k_rc2": p["permeability"]["rc2"],
                    "k_rc2_error": p["permeability"]["rc2_error"], "steady": p["steady"],
                    "steady_after_steps": p["steady_after_steps"], "steps": p["steps"],
                    "restarts": p["restarts"], "drift": p["drift"], "drift_error": p["drift_error"],
                    "temperature": p["temperature"]} for p in pts],
        "warmup": s["steady_state"]["warmup"], "solid_invariant": s["solid"]["invariant"],
        "fluid_particles": s["fluid_particles"], "n_f_nominal": n_nom,
        "n_pore": n_pore, "pore_volume_rc3": pore_volume,
        "density_factor": (n_pore / n_nom) ** 2,
        "seconds": s["wall_seconds"], "mps": s["throughput"]["mps"], "backend": s["backend"],
        "git_commit": s["git_commit"], "precision": s["precision"]}

    # 3. References.
    ex = exact_k_vox2(case, geo)
    rec["exact_k_rc2"] = ex * rpv * rpv if ex is not None else None
    lad = None
    if a.lbm != "off" and (ex is None or a.lbm == "all"):
        refines = a.refines or ([1, 2, 3, 4] if a.size != "gpu" else [1, 2, 3])
        lad = lbm_ladder(a, os.path.join(prep, "solid.h5"), refines, d)
        lad["k_inf_rc2"], lad["error_rc2"] = lad["k_inf"] * rpv ** 2, lad["error"] * rpv ** 2
    rec["lbm_ladder"] = lad
    poi = None
    if case != "spheres" and a.poisson:
        cross = [[pore(z, y, 0) for y in range(ny)] for z in range(nz)]
        poi = poisson_ladder(cross)
        if poi is not None:
            # The mirrored box has twice the image's length along x and the same cross-section:
            # k (superficial, over all voxels) is the same.
            poi["k_inf_rc2"], poi["error_rc2"] = poi["k_inf"] * rpv ** 2, poi["error"] * rpv ** 2
    rec["poisson_2d"] = poi
    if ex is not None:
        ref, ref_err, ref_src = rec["exact_k_rc2"], 0.0, "exact"
    elif lad is not None:
        ref, ref_err, ref_src = lad["k_inf_rc2"], lad["error_rc2"], "LBM ladder k_inf"
    elif poi is not None:
        ref, ref_err, ref_src = poi["k_inf_rc2"], poi["error_rc2"], "2-D Poisson ladder k_inf"
    else:
        ref, ref_err, ref_src = None, None, "none"
    rec["reference"] = {"k_rc2": ref, "error_rc2": ref_err, "source": ref_src}
    if ref:
        rec["ratio_minus_1"] = k / ref - 1
        rec["ratio_minus_1_error"] = (k / ref) * math.sqrt((k_err / k) ** 2 + (ref_err / ref) ** 2)
        rec["ratio_minus_1_error_flux_only"] = (k / ref) * math.sqrt((k_stat / k) ** 2 + (ref_err / ref) ** 2)
    delta, delta_err = no_slip_offset(case, geo, rpv, k, k_stat)
    rec["no_slip_offset_rc"], rec["no_slip_offset_rc_error_flux_only"] = delta, delta_err
    rec["seconds"] = time.time() - t0
    return rec


def fmt(v, e=None, p=4):
    if v is None:
        return "-"
    return f"{v:.{p}g}" + (f" +- {e:.2g}" if e is not None else "")


def table(records):
    lines = ["| case | rc/voxel | particles (fluid) | g | k_mDPD (rc^2) | k_ref (rc^2) | ref | "
             "k/k_ref - 1 | delta (rc) | n_pore / n_f | steady | s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        if "error" in r:
            lines.append(f"| {r['case']} | {r['rc_per_voxel']:g} | failed: {r['error'].splitlines()[0]} |")
            continue
        m = r["mdpd"]
        parts = sum(r["rockprep"]["particles"].values())
        lines.append(
            f"| {r['case']} | {r['rc_per_voxel']:g} | {parts} ({m['fluid_particles']}) | "
            f"{','.join(f'{g:g}' for g in m['forces'])} | {fmt(m['k_rc2'], m['k_rc2_error'])} | "
            f"{fmt(r['reference']['k_rc2'], r['reference']['error_rc2'] or None)} | "
            f"{r['reference']['source']} | "
            + (f"{100 * r['ratio_minus_1']:+.1f}% +- {100 * r['ratio_minus_1_error']:.1f}%"
               if r.get("ratio_minus_1") is not None else "-") + " | "
            + (f"{r['no_slip_offset_rc']:+.3f} +- {r['no_slip_offset_rc_error_flux_only']:.3f}"
               if r.get("no_slip_offset_rc") is not None else "-") + " | "
            f"{m['n_pore']:.3f} / {m['n_f_nominal']:g} | "
            f"{'yes' if all(p['steady'] for p in m['points']) else 'NO'} | {r['seconds']:.0f} |")
    return "\n".join(lines)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.abspath(os.path.join(here, ".."))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n".join(__doc__.splitlines()[1:]))
    p.add_argument("--size", choices=sorted(SIZES), default="tiny")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated, of " + ",".join(CASES))
    p.add_argument("--rc-per-voxel", default="1.0", help="comma-separated list")
    p.add_argument("--pore-vox", type=int, default=0,
                   help="override the size's pore: slit/stair gap h, duct side a, tube diameter D, "
                        "spheres cell L (voxels)")
    p.add_argument("--pore-rc", type=float, default=0.0,
                   help="the same in rc: round(PORE_RC / rc per voxel) voxels at each rc per voxel "
                        "(the same pore in rc at every resolution)")
    p.add_argument("--width-rc", type=float, default=4.0,
                   help="slit: its free width along y in rc (more fluid, less noise; default 4)")
    p.add_argument("--step", type=int, default=2, help="stair: voxels in y per one-voxel step in z")
    p.add_argument("--bin", default=os.path.join(root, "build", "bin"),
                   help="folder of rockprep and rockflow")
    p.add_argument("--backend", default="cpu")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--forces", default="top",
                   help="top (rockprep's largest suggestion), suggested (all four), or g1,g2,...")
    p.add_argument("--viscosity", type=float, default=6.111,
                   help="the full calibration's value (docs/permeability.md)")
    p.add_argument("--viscosity-error", type=float, default=0.041)
    p.add_argument("--sweep-args", default="", help="extra rockflow sweep options (quoted)")
    p.add_argument("--rockprep-args", default="", help="extra rockprep run options (quoted)")
    p.add_argument("--seed", type=int, default=1, help="rockprep's packing and scene seed")
    p.add_argument("--tiles", default="", help="rockprep --tiles DB")
    p.add_argument("--tile-cache", default="", help="rockprep --tile-cache DIR")
    p.add_argument("--lbm", choices=("auto", "all", "off"), default="all",
                   help="auto: the ladder where no exact value exists; all: also for slit and duct "
                        "(a check of the ladder); off")
    p.add_argument("--refines", default="", help="LBM ladder rungs (default 1,2,3,4; gpu size 1,2,3)")
    p.add_argument("--lbm-tau", type=float, default=1.5)
    p.add_argument("--lbm-tolerance", type=float, default=1e-7)
    p.add_argument("--no-poisson", dest="poisson", action="store_false",
                   help="skip the 2-D Poisson cross-check of the cases invariant along x")
    p.add_argument("--reuse", action="store_true",
                   help="keep each step's outputs that exist in OUT (prep, sweep, lbm)")
    p.add_argument("--out", default="out/wall_cases")
    a = p.parse_args()

    cases = [c for c in a.cases.split(",") if c]
    bad = [c for c in cases if c not in CASES]
    if bad:
        p.error(f"unknown case(s) {','.join(bad)}; choose from {','.join(CASES)}")
    try:
        rpvs = [float(v) for v in a.rc_per_voxel.split(",") if v]
        a.refines = [int(v) for v in a.refines.split(",") if v]
    except ValueError as e:
        p.error(f"bad number list: {e}")
    if not rpvs or any(not r > 0 for r in rpvs):
        p.error("--rc-per-voxel needs positive values")
    if a.refines and len(a.refines) < 3:
        p.error("--refines needs three rungs or more")
    if a.pore_vox < 0 or a.pore_rc < 0 or (a.pore_vox and a.pore_rc):
        p.error("give one of --pore-vox and --pore-rc, positive")
    if a.step < 1:
        p.error("--step must be at least 1")
    for tool in ("rockprep", "rockflow"):
        if not os.access(os.path.join(a.bin, tool), os.X_OK):
            p.error(f"{os.path.join(a.bin, tool)} is missing or not executable (give --bin)")
    if a.poisson and np is None:
        print("wall_cases: numpy is not importable here: the 2-D Poisson cross-check is skipped",
              file=sys.stderr)
    os.makedirs(a.out, exist_ok=True)
    a.out = os.path.abspath(a.out)
    summary_path = os.path.join(a.out, "wall_cases.json")
    header = {"command": sys.argv, "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "host_cpus": os.cpu_count(), "bin": os.path.abspath(a.bin), "size": a.size,
              "step": a.step, "pore_vox": a.pore_vox, "pore_rc": a.pore_rc, "width_rc": a.width_rc,
              "seed": a.seed,
              "viscosity": [a.viscosity, a.viscosity_error],
              "sweep_args": a.sweep_args, "lbm_tau": a.lbm_tau}
    records, failed = [], 0
    for rpv in rpvs:
        for case in cases:
            print(f"wall_cases: {case} at {rpv:g} rc per voxel ({a.size}) ...", flush=True)
            try:
                rec = run_case(a, case, rpv)
            except (CaseError, OSError, KeyError, ValueError) as e:
                failed += 1
                rec = {"case": case, "rc_per_voxel": rpv, "error": f"{type(e).__name__}: {e}"}
                print(f"wall_cases: error: {case} at {rpv:g}: {e}", file=sys.stderr, flush=True)
            records.append(rec)
            if "error" not in rec:
                m = rec["mdpd"]
                line = (f"  k_mDPD = {fmt(m['k_rc2'], m['k_rc2_error'])} rc^2, "
                        f"reference {fmt(rec['reference']['k_rc2'], rec['reference']['error_rc2'])}"
                        f" ({rec['reference']['source']})")
                if rec.get("ratio_minus_1") is not None:
                    line += f": {100 * rec['ratio_minus_1']:+.2f}% +- {100 * rec['ratio_minus_1_error']:.2f}%"
                if rec["lbm_ladder"] and rec["reference"]["source"] != "LBM ladder k_inf":
                    lad = rec["lbm_ladder"]
                    line += f"; LBM ladder {fmt(lad['k_inf_rc2'], lad['error_rc2'])}"
                if rec["poisson_2d"]:
                    line += f"; 2-D Poisson {fmt(rec['poisson_2d']['k_inf_rc2'], rec['poisson_2d']['error_rc2'])}"
                if rec["no_slip_offset_rc"] is not None:
                    line += f"; delta = {rec['no_slip_offset_rc']:+.3f} rc"
                line += f"; n_pore {m['n_pore']:.3f} (n_f {m['n_f_nominal']:g}); {rec['seconds']:.0f} s"
                print(line, flush=True)
            tmp = summary_path + ".part"
            with open(tmp, "w") as f:
                json.dump({**header, "cases": records}, f, indent=1)
            os.replace(tmp, summary_path)
    print(table(records))
    print(f"wall_cases: {len(records) - failed} of {len(records)} cases ran; {summary_path}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
