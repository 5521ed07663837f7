#!/usr/bin/env python3
"""Turns the output of `rockflow study` into docs/accuracy.md: tables and PNG plots.

    accuracy_report.py --study DIR/study.json --out OUTDIR [--packing-json FILE]

Writes OUTDIR/accuracy.md and OUTDIR/accuracy/*.png, and copies the raw study data (study.json,
the CSVs, the packing JSON) into OUTDIR/accuracy/ next to the plots. Every table and sentence with
a number comes from the JSON; the method text is fixed here. Needs numpy and matplotlib.
"""
import argparse
import json
import math
import os
import re
import shutil
import sys

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STUDIES = ["timestep", "precision", "resolution", "reorder", "effects"]


# ------------------------------------------------------------------------------------------------
# Formatting


def isnum(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def f(v, digits=4):
    """A number with `digits` significant digits; a dash for missing values."""
    if not isnum(v):
        return "-"
    if v == 0:
        return "0"
    return "%.*g" % (digits, v)


def pm(v, e, digits=4, edigits=2):
    if not isnum(v):
        return "-"
    if not isnum(e) or e == 0:
        return f(v, digits)
    return "%s ± %s" % (f(v, digits), f(e, edigits))


def pct(v, e=None, digits=3):
    """A relative deviation in percent with its sign, and its error when given."""
    if not isnum(v):
        return "-"
    s = "%+.*g%%" % (digits, 100 * v)
    if isnum(e) and e > 0:
        s += " ± %.2g%%" % (100 * e)
    return s


def signed(v, e=None, digits=3):
    if not isnum(v):
        return "-"
    s = "%+.*g" % (digits, v)
    if isnum(e) and e > 0:
        s += " ± %.2g" % e
    return s


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        out.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(out) + "\n"


def ratio_error(a, ea, b, eb):
    """Error of a / b - 1 from the errors of a and b (independent)."""
    if not all(isnum(x) for x in (a, b)) or b == 0:
        return float("nan")
    ea = ea if isnum(ea) else 0.0
    eb = eb if isnum(eb) else 0.0
    return abs(a / b) * math.hypot(ea / a if a else 0.0, eb / b)


# ------------------------------------------------------------------------------------------------
# Sections


def header_section(doc, small):
    lines = []
    lines.append("# What accuracy costs\n")
    lines.append(
        "How much accuracy each choice buys and what it costs in time, so that a run can pick its "
        "point: the time step, single or double precision, the packing of walls, the resolution "
        "(rc per pore width), the cell-list settings, and every piece of physics and every "
        "observable switched on alone. Each row gives an accuracy and the time it costs. Every "
        "comparison ran in one process on one device (`rockflow study`), so the ratios are fair; "
        "the raw rows are in [accuracy/study.json](accuracy/study.json) and the CSVs beside it.\n"
    )
    if small:
        lines.append(
            "> **These numbers are from a %s run at the `%s` size (%s), not the GPU study.** At "
            "this size the boxes and runs are short, so the error bars are wide, and on a CPU "
            "shared with other jobs the timings are noisy. The GPU run "
            "(`--size full --backend cuda`) replaces them.\n" % (doc["backend"].upper(), doc["size"], doc["device"])
        )
    lines.append(
        table(
            ["run", ""],
            [
                ["device", doc.get("device", "-")],
                ["backend", "%s%s" % (doc.get("backend"), (", %d OpenMP thread%s" % (doc["threads"], "s" if doc["threads"] > 1 else "")) if doc.get("threads") else "")],
                ["date (UTC)", doc.get("date", "-")],
                ["mesorock", "%s, commit %s" % (doc.get("mesorock_version", "-"), doc.get("git_commit", "-"))],
                ["host", doc.get("host", "-")],
                ["size, seed", "%s, %s" % (doc.get("size"), doc.get("seed"))],
                ["command", "`%s`" % doc.get("command", "-")],
                ["wall time of the study", "%s s" % f(doc.get("seconds"), 4)],
            ],
        )
    )
    lines.append(
        "\nRegenerate this page with one command (it runs `rockflow study` and this report):\n\n"
        "```\nbash scripts/accuracy.sh --backend cuda --size full --out OUT "
        "[--packing-json PACKING.json]\n```\n\n"
        "which writes OUT/accuracy.md and OUT/accuracy/ (plots and raw data); copy both over "
        "docs/. `--size small` runs on a 2-core CPU in a few minutes; `--size tiny` is the smoke "
        "test of ctest (`StudyCommand.*`).\n"
    )
    lines.append(
        "**Units and cost.** Reduced units (rc = m = kBT = 1, time unit tau). The cost of a row is "
        "the wall time per particle per unit of simulated time, in ns: a run of N particles over "
        "T tau costs N x T x that. It comes from the measured speed in million particle-steps per "
        "second (MPS/s): cost = 1000 / (MPS/s x dt) ns. Speeds are measured on a timed stretch of "
        "steps without sampling, from a synchronised start to a synchronised end (on a GPU, "
        "all queued work done). The "
        "liquid of the accuracy studies is the validation cases' mDPD liquid: A = -40, B = 25, "
        "rd = 0.75, gamma = 4.5, rho = 7, the papers' density kernel, lambda = 0.5.\n"
    )
    return "\n".join(lines)


def timestep_section(st, outdir, figures):
    p = st["parameters"]
    rows = st["rows"]
    lines = ["## 1. Time step\n"]
    liquid = p["liquid"]
    b, v, s = p["bulk"], p["viscosity"], p["slit"]
    lines.append(
        "Each time step runs the same three systems, in %s precision, each started from one "
        "state brought to steady state at dt = 0.01 (%s tau), then %s/%s/%s tau of "
        "equilibration at its own dt and samples every 0.1 tau:\n"
        % (p.get("precision", "double"), f(p.get("pre_equilibrate_tau_at_dt_0.01")),
           f(b["equilibrate_tau"]), f(v["equilibrate_tau"]), f(s["equilibrate_tau"]))
    )
    lines.append(
        "- **temperature and pressure**: a periodic cube of edge %s (%d particles), %s tau "
        "sampled. T is the kinetic temperature of all particles against the thermostat's kBT = 1; "
        "p is the kinetic + conservative pressure (Groot & Warren's definition, as the eos-mdpd "
        "case), compared with the smallest time step's value and with Warren's fit "
        "p = rho + alpha A rho^2 + 2 alpha B rd^4 (rho^3 - c rho^2 + d) = %s at rho = 7 (the fit "
        "itself is good to about 1 here: eos-mdpd measures 61.15 at dt = 0.01).\n"
        % (f(b["edge"]), b["particles"], f(b["sample_tau"]), f(p.get("warren_pressure")))
    )
    lines.append(
        "- **viscosity**: reverse Poiseuille flow as the `viscosity` validation case "
        "(pipeline/flow/validation_interfaces.cpp): box %s x %s x %s (%d particles), force g = "
        "%s (peak shear rate %s, linear response), %s tau sampled; eta from a parabola per half, "
        "its error from the scatter over blocks of at least 2 tau (at most 20). Reference: %s ± %s (the `viscosity` case at full size, "
        "dt = 0.01).\n"
        % (f(v["box"][0]), f(v["box"][1]), f(v["box"][2]), v["particles"], f(v["g"], 3),
           f(v["peak_shear_rate"]), f(v["sample_tau"]), f(v["reference"]), f(v["reference_error"], 2))
    )
    lines.append(
        "- **permeability**: body-force flow along x in a slit of width H = %s between walls of "
        "frozen liquid %s rc thick with the wall model (as `poiseuille-walls`: "
        "pipeline/flow/validation_walls.cpp, `liquid_with_walls`), %s x %s in x-y, %d particles "
        "(%d fluid), g = %s (peak shear rate %s), %s tau sampled. **k = eta u / (n g)**: u the mean "
        "velocity of the fluid particles along the force, n = N_fluid / (H Lx Ly) their number "
        "density over the pore between the cut planes (%s), g the force per particle, eta = %s "
        "(the reference viscosity, the same for every row, so that k measures the flow rate a "
        "user would get). For Stokes flow with no slip at the cut planes, k = H^2/12 = %s. Compared "
        "with the smallest time step's k.\n"
        % (f(s["width"]), f(s["wall_thickness"]), f(s["lxy"]), f(s["lxy"]), s["particles"],
           s["fluid_particles"], f(s["g"], 3), f(s["peak_shear_rate"]), f(s["sample_tau"]),
           f(s["fluid_density"]), f(v["reference"]), f(s["stokes_permeability"]))
    )
    lines.append(
        "- **cost**: the MPS/s of the same liquid, the bulk cube replicated to %d particles, at "
        "each dt (%d timed steps), and the ns per particle per tau that follow. The MPS/s of the "
        "three small accuracy boxes (a timed stretch of %d steps each) are in the CSV.\n"
        % (p.get("scale_particles", 0), p.get("scale_steps", 0), p.get("timed_steps", 0))
    )
    ref = rows[0] if rows else {}
    t = []
    for r in rows:
        if not r.get("stable"):
            t.append([f(r["dt"]), "**unstable**: " + r.get("failure", ""), "", "", "", "", "", "", "", ""])
            continue
        t.append([
            f(r["dt"]),
            pm(r["temperature"], r["temperature_error"], 5),
            pct(r["temperature_deviation"], r["temperature_error"]),
            pm(r["pressure"], r["pressure_error"], 5),
            signed(r["pressure_vs_reference_dt"], r["pressure_error"]),
            signed(r["pressure_vs_warren"]),
            pm(r["viscosity"], r["viscosity_error"]),
            pct(r["viscosity_vs_reference"], ratio_error(r["viscosity"], r["viscosity_error"], v["reference"], 0)),
            pct(r["permeability_vs_reference_dt"], ratio_error(r["permeability"], r["permeability_error"], ref.get("permeability"), ref.get("permeability_error")) if r is not ref else None),
            "%s (%s MPS/s)" % (f(r["ns_per_particle_tau"], 3), f(r["mps_at_scale"], 4)),
        ])
    lines.append(
        table(
            ["dt", "T", "T - 1", "p", "p - p(dt=%s)" % f(ref.get("dt")), "p - Warren", "eta",
             "eta / %s - 1" % f(v["reference"]), "k / k(dt=%s) - 1" % f(ref.get("dt")),
             "cost: ns per particle per tau"],
            t,
        )
    )
    lines.append(
        "\nk itself (rc^2), its deviation from H^2/12 and the slip length of the fitted profile, "
        "per dt: %s.\n"
        % "; ".join(
            "dt %s: k = %s (%s), slip %s" % (f(r["dt"]), pm(r["permeability"], r["permeability_error"]),
                                              pct(r["permeability_vs_stokes"]), f(r["slip_length"], 2))
            for r in rows if r.get("stable"))
    )
    lines.append(
        "\n**How to read it.** Errors are one standard error (block averages). Move down the table "
        "to pay less per tau; the columns show what each step up in dt costs in accuracy. A "
        "deviation smaller than its error bar is not resolved at this size.\n"
    )
    # Plot: each quantity's deviation against the cost, one point per dt.
    ok = [r for r in rows if r.get("stable") and isnum(r.get("ns_per_particle_tau"))]
    if ok:
        fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
        panels = [
            ("temperature: T - 1", [r["temperature_deviation"] for r in ok], [r["temperature_error"] for r in ok]),
            ("pressure: p - p(smallest dt)", [r["pressure_vs_reference_dt"] for r in ok], [r["pressure_error"] for r in ok]),
            ("viscosity: eta / %s - 1" % f(v["reference"]), [r["viscosity_vs_reference"] for r in ok],
             [ratio_error(r["viscosity"], r["viscosity_error"], v["reference"], 0) for r in ok]),
            ("permeability: k / k(smallest dt) - 1", [r["permeability_vs_reference_dt"] for r in ok],
             [ratio_error(r["permeability"], r["permeability_error"], ref.get("permeability"), 0) for r in ok]),
        ]
        x = np.array([r["ns_per_particle_tau"] for r in ok])
        for ax, (title, y, e) in zip(axes.flat, panels):
            y = np.array([v_ if isnum(v_) else np.nan for v_ in y], dtype=float)
            e = np.array([v_ if isnum(v_) else 0.0 for v_ in e], dtype=float)
            ax.errorbar(x, y, yerr=e, fmt="o-", capsize=3)
            for xi, yi, r in zip(x, y, ok):
                ax.annotate("dt %s" % f(r["dt"]), (xi, yi), textcoords="offset points", xytext=(4, 4), fontsize=8)
            ax.axhline(0, color="grey", lw=0.8)
            ax.set_xscale("log")
            ax.set_title(title, fontsize=10)
            ax.set_xlabel("cost: ns per particle per tau")
        fig.suptitle("Time step: error against cost (%s, %s)" % (figures["device_short"], figures["size"]), fontsize=11)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "accuracy", "timestep.png"), dpi=110)
        plt.close(fig)
        lines.append("\n![time step: error against cost](accuracy/timestep.png)\n")
    return "\n".join(lines)


def precision_section(st):
    rows = st["rows"]
    lines = ["## 2. Single against double precision\n"]
    lines.append(
        "The same three systems and the same starting state at dt = 0.01, once in double and "
        "once in single precision (storage and pair arithmetic in float; the pair random numbers "
        "and the reductions in double either way). Deviations are single minus double; cost from "
        "the replicated bulk liquid (%d particles) in each precision.\n" % st["parameters"].get("scale_particles", 0)
    )
    d = next((r for r in rows if r["precision"] == "double"), None)
    t = []
    for r in rows:
        if not r.get("stable"):
            t.append([r["precision"], "**unstable**: " + r.get("failure", ""), "", "", "", "", ""])
            continue
        is_ref = r is d
        t.append([
            r["precision"],
            pm(r["temperature"], r["temperature_error"], 5),
            pm(r["pressure"], r["pressure_error"], 5) + ("" if is_ref else " (%s)" % signed(r["pressure_vs_reference_dt"])),
            pm(r["viscosity"], r["viscosity_error"]) + ("" if is_ref or not d else " (%s)" % pct(r["viscosity"] / d["viscosity"] - 1 if isnum(r["viscosity"]) and isnum(d["viscosity"]) else None)),
            pm(r["permeability"], r["permeability_error"]) + ("" if is_ref else " (%s)" % pct(r["permeability_vs_reference_dt"])),
            f(r["mps_at_scale"], 4),
            f(r["ns_per_particle_tau"], 3),
        ])
    lines.append(table(["precision", "T", "p (single - double)", "eta (single / double - 1)", "k (single / double - 1)", "MPS/s", "ns per particle per tau"], t))
    if d and len(rows) > 1 and isnum(rows[1].get("mps_at_scale")) and isnum(d.get("mps_at_scale")):
        lines.append("\nSingle precision runs at %s x the speed of double here.\n" % f(rows[1]["mps_at_scale"] / d["mps_at_scale"], 3))
    return "\n".join(lines)


def parse_packing(path):
    """The JSON object(s) of `rockprep validate packing-walls --json`, one per line or one file."""
    text = open(path).read().strip()
    objs = []
    try:
        j = json.loads(text)
        objs = j if isinstance(j, list) else [j]
    except json.JSONDecodeError:
        for line in text.splitlines():
            line = line.strip()
            if line.startswith("{"):
                objs.append(json.loads(line))
    return objs


PACKING_NOTE = re.compile(
    r"^(?P<name>\w+) walls: (?P<wall>\d+) wall particles, (?P<fluid>\d+) fluid; near-wall deviation "
    r"of T (?P<T>[-+\d.eE]+)% \+- (?P<Te>[-+\d.eE]+)%, of density (?P<rho>[-+\d.eE]+)% \+- "
    r"(?P<rhoe>[-+\d.eE]+)%; .*?preprocessing (?P<pack>[-+\d.eE]+) s packing"
    r"(?: \+ (?P<tiles>[-+\d.eE]+) s building the tile set)?")


def packing_section(path):
    lines = ["## 3. Lattice against tile packing of walls\n"]
    lines.append(
        "Near-wall artefacts against preprocessing time: a wall packed on a lattice and the same "
        "wall packed from the database of equilibrated tiles (the 2020 paper's method), each next "
        "to the same fluid and equilibrated with the solver; the near-wall deviation is the "
        "noise-corrected RMS over four layers of 0.25 rc of the fluid's temperature (density) "
        "relative to its bulk value. Measured by `rockprep validate packing-walls --json` (rockprep "
        "links OpenVDB and runs on the CPU: the GPU machine cannot build it).\n"
    )
    if not path:
        lines.append(
            "**Not measured in this run**: no packing JSON was given. Produce it with "
            "`build/bin/rockprep validate packing-walls --size full --json > packing.json` and pass "
            "`--packing-json packing.json` to scripts/accuracy.sh.\n"
        )
        return "\n".join(lines)
    try:
        objs = parse_packing(path)
    except (OSError, ValueError) as e:
        lines.append("**Not shown**: %s could not be read (%s).\n" % (path, e))
        return "\n".join(lines)
    for j in objs:
        lines.append("Case `%s`: %s (%s s).\n" % (j.get("case", "?"), "pass" if j.get("pass") else "FAIL", f(j.get("seconds"), 3)))
        parsed = []
        for n in j.get("notes", []):
            m = PACKING_NOTE.match(n)
            if m:
                parsed.append(m.groupdict())
        if parsed:
            t = []
            for m in parsed:
                pre = float(m["pack"]) + (float(m["tiles"]) if m.get("tiles") else 0.0)
                t.append([m["name"], m["wall"], m["fluid"], "%s%% ± %s%%" % (m["T"], m["Te"]),
                          "%s%% ± %s%%" % (m["rho"], m["rhoe"]),
                          "%s s" % m["pack"] + (" + %s s tile set" % m["tiles"] if m.get("tiles") else ""),
                          f(pre, 3)])
            lines.append(table(["packing", "wall particles", "fluid particles", "near-wall T deviation",
                                "near-wall density deviation", "preprocessing", "total s"], t))
        q = j.get("quantities", [])
        if q:
            lines.append("\nThe case's judged quantities:\n")
            lines.append(table(["quantity", "measured", "error", "reference", "result"],
                               [[x.get("name", ""), f(x.get("measured")), f(x.get("error"), 2),
                                 ("<= " if x.get("comparison") == "at_most" else (">= " if x.get("comparison") == "at_least" else "")) + f(x.get("reference")),
                                 "pass" if x.get("pass") else "FAIL"] for x in q]))
        if not parsed:
            lines.append("\nNotes of the case (their format was not recognised for the table):\n")
            for n in j.get("notes", []):
                lines.append("- " + n)
            lines.append("")
    return "\n".join(lines)


def resolution_section(st, outdir, figures):
    p = st["parameters"]
    rows = st["rows"]
    lines = ["## 4. Resolution: rc per pore width\n"]
    lines.append(
        "Slits of width H = %s rc between walls of frozen liquid %s rc thick (the wall model on), "
        "driven by a body force for a peak shear rate of %s at the walls, dt = %s, %s precision, "
        "%s tau sampled after %s. Each slit holds about the same fluid volume (H Lx Ly = %s, "
        "Lx = Ly = sqrt(%s / H), at least 3). k = eta u / (n g) as in study 1, eta = %s. "
        "**The hydrodynamic wall is placed at the cut plane**, where the frozen liquid ends and "
        "the fluid begins: the wall model imposes no slip there (poiseuille-walls measures slip "
        "lengths under 0.3 rc from it), so Stokes flow gives k = H^2/12 with H the distance "
        "between the cut planes. The slip length of the table is the fitted parabola's (half the "
        "difference between its zeros' distance and H; the fit leaves out 0.5 rc at each wall and "
        "is made only for H >= 3, and only when the profile opens downwards).\n"
        % (", ".join(f(w) for w in p["widths"]), f(p["wall_thickness"]), f(p["peak_shear_rate"]),
           f(p["dt"]), p["precision"], f(p["sample_tau"]), f(p["equilibrate_tau"]),
           f(p["pore_volume_per_slit"]), f(p["pore_volume_per_slit"]), f(p["viscosity"]))
    )
    t = []
    for r in rows:
        if not r.get("stable"):
            t.append([f(r["width"]), "**unstable**: " + r.get("failure", ""), "", "", "", "", "", ""])
            continue
        t.append([
            f(r["width"]), "%d (%d fluid)" % (r["particles"], r["fluid_particles"]),
            pm(r["permeability"], r["permeability_error"]), f(r["stokes_permeability"]),
            pct(r["permeability_vs_stokes"], r["permeability_vs_stokes_error"]),
            f(r["slip_length"], 2),
            "%s / %s" % (f(r["wall_temperature"], 4), f(r["bulk_temperature"], 4)),
            "%s (%s MPS/s)" % (f(r["ns_per_particle_tau"], 3), f(r["mps"], 3)),
            f(1e3 * r["seconds_per_tau_per_area"], 3) if isnum(r.get("seconds_per_tau_per_area")) else "-",
        ])
    lines.append(table(["H (rc)", "particles", "k", "H^2/12", "k / (H^2/12) - 1", "slip (rc)",
                        "T next to wall / bulk", "cost: ns per particle per tau", "ms per tau per rc^2 of slit"], t))
    lines.append(
        "\n**How to read it.** For a pore of physical width W, H = W / rc: more rc per pore width "
        "means more particles per pore volume (as H^3 for a fixed pore) and, for the flow to "
        "develop (a time of order H^2 / nu in tau, nu = eta / rho = 1), more steps. The last "
        "column is the measured time per tau for a unit area of slit wall at each width, walls "
        "included.\n"
    )
    ok = [r for r in rows if r.get("stable") and isnum(r.get("permeability"))]
    if ok:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        H = np.array([r["width"] for r in ok])
        axes[0].errorbar(H, [r["permeability_vs_stokes"] * 100 for r in ok],
                         yerr=[100 * (r["permeability_vs_stokes_error"] or 0) for r in ok], fmt="o-", capsize=3)
        axes[0].axhline(0, color="grey", lw=0.8)
        axes[0].set_xlabel("slit width H (rc)")
        axes[0].set_ylabel("k / (H^2/12) - 1 (%)")
        axes[0].set_title("permeability error against resolution", fontsize=10)
        axes[1].plot(H, [1e3 * r["seconds_per_tau_per_area"] for r in ok], "o-")
        axes[1].set_xlabel("slit width H (rc)")
        axes[1].set_ylabel("ms per tau per rc^2 of slit")
        axes[1].set_title("cost", fontsize=10)
        fig.suptitle("Resolution (%s, %s)" % (figures["device_short"], figures["size"]), fontsize=11)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "accuracy", "resolution.png"), dpi=110)
        plt.close(fig)
        lines.append("\n![resolution](accuracy/resolution.png)\n")
    return "\n".join(lines)


def reorder_section(st, outdir, figures):
    p = st["parameters"]
    rows = st["rows"]
    summ = st.get("summary", {})
    lines = ["## 5. Reorder interval, skin and cells per rc\n"]
    lines.append(
        "`SimulationOptions::reorder_every` and `skin` (`rockflow bench --reorder-every N --skin "
        "S`): the storage is sorted by cell every N steps over cells of rc + skin, and sooner when a "
        "particle has moved skin/2; `cells_per_cutoff` (`--cells-per-rc`) splits each cell. Each "
        "configuration runs the same equilibrated state (%s precision, dt = %s, %s warm-up and %s "
        "timed steps) of the bulk liquid (rho = 6.9, as `rockflow bench --case bulk`) and the porous "
        "benchmark; the default (N = 1, no skin, 1 cell per rc) runs first and again last. These "
        "settings change only the order of the force sums, so results differ at round-off: checked "
        "here by running every configuration %s steps from the same double-precision state "
        "(%s particles) and comparing with the default, largest position difference %s rc, "
        "largest temperature difference %s. The temperature and pressure after the timed run "
        "(single precision, where round-off differences have grown chaotically) agree within their "
        "fluctuations.\n"
        % (p["precision"], f(p["dt"]), p["warm_steps"], p["timed_steps"], p["check_steps"],
           p["check_particles"], f(summ.get("check_max_position_difference"), 2),
           f(summ.get("check_max_temperature_difference"), 2))
    )
    for system in ("bulk", "porous"):
        rs = [r for r in rows if r["system"] == system]
        if not rs:
            continue
        lines.append("\n**%s** (%d particles): MPS/s, and speed-up over the default in brackets.\n" % (system, rs[0]["particles"]))
        defaults = [r for r in rs if r["reorder_every"] == 1 and r["skin"] == 0 and r["cells_per_rc"] == 1]
        cells = [r for r in rs if r["cells_per_rc"] > 1]
        skins = sorted(set(r["skin"] for r in rs if r["skin"] > 0))
        reorders = sorted(set(r["reorder_every"] for r in rs if r["skin"] > 0))
        t = []
        for rr in reorders:
            row = ["N = %d" % rr]
            for s in skins:
                m = [r for r in rs if r["reorder_every"] == rr and r["skin"] == s and r["cells_per_rc"] == 1]
                row.append("%s (%s)" % (f(m[0]["mps"], 4), f(m[0]["speedup_vs_default"], 3)) if m and isnum(m[0].get("mps")) else "-")
            t.append(row)
        lines.append(table(["reorder every"] + ["skin %s" % f(s) for s in skins], t))
        extra = ["default (N = 1, skin 0, 1 cell per rc), run %d: %s MPS/s, T %s, p %s" %
                 (r["repeat"], f(r["mps"], 4), f(r["temperature_end"], 4), f(r["pressure_end"], 4)) for r in defaults]
        extra += ["%d cells per rc: %s MPS/s (%s)" % (r["cells_per_rc"], f(r["mps"], 4), f(r["speedup_vs_default"], 3)) for r in cells]
        ts = [r["temperature_end"] for r in rs if isnum(r.get("temperature_end"))]
        if ts:
            extra.append("temperature after the timed run over all configurations: %s to %s" % (f(min(ts), 4), f(max(ts), 4)))
        lines.append("\n" + "\n".join("- " + e for e in extra) + "\n")
    if rows:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        for ax, system in zip(axes, ("bulk", "porous")):
            rs = [r for r in rows if r["system"] == system]
            for s in sorted(set(r["skin"] for r in rs if r["skin"] > 0)):
                m = sorted([r for r in rs if r["skin"] == s and r["cells_per_rc"] == 1], key=lambda r: r["reorder_every"])
                ax.plot([r["reorder_every"] for r in m], [r["mps"] if isnum(r.get("mps")) else np.nan for r in m], "o-", label="skin %s" % f(s))
            for r in rs:
                if r["reorder_every"] == 1 and r["skin"] == 0 and r["cells_per_rc"] == 1 and isnum(r.get("mps")):
                    ax.axhline(r["mps"], color="grey", ls="--", lw=0.8)
            ax.set_xscale("log")
            ax.set_xlabel("reorder every N steps")
            ax.set_ylabel("MPS/s")
            ax.set_title(system + " (dashed: default)", fontsize=10)
            ax.legend(fontsize=8)
        fig.suptitle("Reorder interval and skin (%s, %s)" % (figures["device_short"], figures["size"]), fontsize=11)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "accuracy", "reorder.png"), dpi=110)
        plt.close(fig)
        lines.append("![reorder interval and skin](accuracy/reorder.png)\n")
    return "\n".join(lines)


def effects_section(st, outdir, figures):
    p = st["parameters"]
    rows = st["rows"]
    s = st.get("summary", {})
    lines = ["## 6. What each effect costs\n"]
    lines.append(
        "The %s (%d particles, %s precision, dt = %s), equilibrated once; every scene starts from "
        "that state, runs %s warm-up steps and is timed as the fastest of %s stretches of %s steps "
        "in the same run (load spikes on a shared machine only add time). The **bare pass** is the "
        "standard DPD conservative force alone (a = 25 for every pair: no density pass, no "
        "thermostat, no body force, nothing else); each scene switches one effect on over it (the "
        "wall model needs the thermostat, so its cost is over the thermostat scene). Every scene "
        "has the same four particle types (fluid left and right of x = Lx/2, the frozen wall rings, "
        "and a layer of fluid at z in [15.1, 15.9) that the rigid-slab scene moves as one body), so "
        "only the effect differs. Observables are sampled every %s steps, as a scene's [output] "
        "would. The bare pass is repeated %d times, spread over the list, to measure the noise: "
        "mean %s ms per step, standard deviation %s ms (%s), range %s to %s.\n"
        % (p["system"], p["particles"], p["precision"], f(p["dt"]), p["warm_steps"],
           p["timed_stretches"], p["steps_per_stretch"],
           p["observable_interval"], s.get("bare_repeats", 0), f(s.get("bare_ms_per_step_mean"), 4),
           f(s.get("bare_ms_per_step_sd"), 2), pct(s.get("bare_noise_relative")),
           f(s.get("bare_ms_per_step_min"), 4), f(s.get("bare_ms_per_step_max"), 4))
    )
    t = []
    for r in rows:
        t.append([
            "`%s`" % r["scene"], r["effect"], "yes" if r["active"] else "no",
            f(r["ms_per_step"], 4), f(r["mps"], 4),
            pct(r["cost_vs_base"]) + ("" if r["base"] == "bare" else " (over %s)" % r["base"]),
            f(r["excess_in_bare_sd"], 2),
            "yes" if r["within_bare_noise"] else ("no" if r["active"] else "**no**"),
        ])
    lines.append(table(["scene", "effect", "acts", "ms per step", "MPS/s", "cost over the bare pass",
                        "excess in bare s.d.", "within noise"], t))
    inactive = [r for r in rows if not r["active"] and not r["scene"].startswith("bare")]
    verdict = s.get("inactive_scenes_within_noise")
    lines.append(
        "\n**Acceptance: a scene without an effect runs no slower than the bare pass plus noise.** "
        "Criterion: ms per step <= bare mean + 2 standard deviations of the repeated bare pass. "
        "The scenes that declare effects in inactive form (%s): %s.\n"
        % (", ".join("`%s`" % r["scene"] for r in inactive),
           "**all within the noise**" if verdict else "**not all within the noise** (see the table; on a shared CPU other jobs add noise the repeats may not catch)")
    )
    lines.append(
        "Why an unused effect costs nothing: runtime choices become template parameters in one "
        "place (sim/terms.h), so a scene without the thermostat, the density pass, a body force or "
        "the wall model runs a pass compiled without them; virtual walls, slabs and injection are "
        "counted loops or host-side checks per step; observables are computed on demand and own no "
        "memory until asked for.\n"
    )
    ok = [r for r in rows if isnum(r.get("ms_per_step"))]
    if ok and isnum(s.get("bare_ms_per_step_mean")):
        fig, ax = plt.subplots(figsize=(9, 0.35 * len(ok) + 1.5))
        mean, sd = s["bare_ms_per_step_mean"], s.get("bare_ms_per_step_sd") or 0.0
        y = np.arange(len(ok))[::-1]
        vals = [100 * (r["ms_per_step"] / mean - 1) for r in ok]
        colours = ["tab:grey" if r["scene"].startswith("bare") else ("tab:blue" if r["active"] else "tab:green") for r in ok]
        ax.barh(y, vals, color=colours, zorder=2)
        ax.axvspan(-200 * sd / mean, 200 * sd / mean, color="orange", alpha=0.25, zorder=0,
                   label="bare mean ± 2 s.d.")
        ax.set_yticks(y)
        ax.set_yticklabels([r["scene"] for r in ok], fontsize=8)
        ax.axvline(0, color="black", lw=0.8)
        ax.set_xlabel("time per step over the bare pass (%)")
        ax.set_title("Cost of each effect (blue: acts, green: declared but inactive, grey: bare repeats)\n(%s, %s)" % (figures["device_short"], figures["size"]), fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "accuracy", "effects.png"), dpi=110)
        plt.close(fig)
        lines.append("![cost of each effect](accuracy/effects.png)\n")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study", required=True, help="study.json written by rockflow study")
    ap.add_argument("--out", required=True, help="folder for accuracy.md and accuracy/")
    ap.add_argument("--packing-json", default="", help="rockprep validate packing-walls --json output")
    a = ap.parse_args()
    try:
        doc = json.load(open(a.study))
    except (OSError, ValueError) as e:
        sys.exit("accuracy_report: %s: %s" % (a.study, e))
    studies = doc.get("studies", {})
    if not studies:
        sys.exit("accuracy_report: %s: holds no study" % a.study)
    data = os.path.join(a.out, "accuracy")
    os.makedirs(data, exist_ok=True)
    src = os.path.dirname(os.path.abspath(a.study))
    if os.path.abspath(data) != src:
        shutil.copy(a.study, os.path.join(data, "study.json"))
        for name in studies:
            csv = os.path.join(src, studies[name].get("csv", ""))
            if os.path.isfile(csv):
                shutil.copy(csv, os.path.join(data, os.path.basename(csv)))
    packing = a.packing_json
    if packing:
        if not os.path.isfile(packing):
            sys.exit("accuracy_report: %s: no such packing JSON" % packing)
        if os.path.abspath(os.path.dirname(packing)) != os.path.abspath(data) or os.path.basename(packing) != "packing.json":
            shutil.copy(packing, os.path.join(data, "packing.json"))
    small = doc.get("size") != "full"
    device = doc.get("device", "")
    figures = {"device_short": device.split(" (")[0].split(",")[0], "size": "size " + doc.get("size", "?")}
    parts = [header_section(doc, small)]
    if "timestep" in studies:
        parts.append(timestep_section(studies["timestep"], a.out, figures))
    else:
        parts.append("## 1. Time step\n\nNot run in this study (`--only`).\n")
    if "precision" in studies:
        parts.append(precision_section(studies["precision"]))
    else:
        parts.append("## 2. Single against double precision\n\nNot run in this study (`--only`).\n")
    parts.append(packing_section(packing))
    if "resolution" in studies:
        parts.append(resolution_section(studies["resolution"], a.out, figures))
    else:
        parts.append("## 4. Resolution: rc per pore width\n\nNot run in this study (`--only`).\n")
    if "reorder" in studies:
        parts.append(reorder_section(studies["reorder"], a.out, figures))
    else:
        parts.append("## 5. Reorder interval, skin and cells per rc\n\nNot run in this study (`--only`).\n")
    if "effects" in studies:
        parts.append(effects_section(studies["effects"], a.out, figures))
    else:
        parts.append("## 6. What each effect costs\n\nNot run in this study (`--only`).\n")
    text = "\n".join(parts).rstrip() + "\n"
    target = os.path.join(a.out, "accuracy.md")
    tmp = os.path.join(a.out, ".accuracy.md.partial")
    with open(tmp, "w") as fh:
        fh.write(text)
    os.replace(tmp, target)
    print("accuracy_report: wrote %s" % target)


if __name__ == "__main__":
    main()
