// flooding-mini: the 2020 paper's miniature flooding set-up (Sec. 5.2; docs/physics.md), small. A
// porous block of grains (frozen-liquid walls with the wall model of Li et al. 2018) is filled
// with the source fluid; a reservoir of source fluid behind it is held by a back-pressure slab,
// and a reservoir of working fluid in front of it is pushed by a slab at a higher pressure. A
// virtual wall at the block's inlet face keeps the working fluid out while the set-up settles;
// once it goes, the pressure difference drives the working fluid in and the source fluid out.
// Both fluids have the same parameters (single-phase flooding, as in the paper). Reflective box
// faces along the flow axis x, periodic across it.
//
// Judged: the recovery (share of the source fluid initially in the block that has left it) at
// the end, no fluid particle deeper in a grain than the skin the no-penetration case allows, no
// fluid particle behind either slab, no working fluid in the block while the virtual wall
// stands, a finite temperature near kBT (stability), and the pressure in each reservoir (region
// stress, time-averaged) against the one its slab applies.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <tuple>

#include "mesorock/errors.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/validation.h"
#include "pipeline/flow/wall_liquid.h"
#include "sim/init.h"

namespace mesorock::pipeline {

namespace {

using namespace wall_liquid;
using Clock = std::chrono::steady_clock;

struct FloodGeometry {
  double reservoir = 5;       // length of each fluid reservoir along x
  double block = 7;           // length of the porous block
  double width = 5;           // edge across the flow (periodic y and z)
  double slab = 2;            // slab thickness
  double room = 4;            // free space behind the back-pressure slab
  int grains = 2;             // spheres in the block (random centres, periodic in y and z)
  double radius = 1.8;        // their radius
  double back_pressure = 60;  // about the A = -40 liquid's pressure at rho = 7 (Warren: 60.2)
  double drive = 15;          // pushing slab pressure minus back pressure
  std::uint64_t settle = 400, flood = 2000, every = 400;
};

FloodGeometry flood_geometry(bool full) {
  FloodGeometry g;
  if (full) {
    g.reservoir = 8;
    g.block = 16;
    g.width = 12;
    g.room = 8;
    g.grains = 14;
    g.radius = 2.8;
    g.settle = 1000;
    g.flood = 14000;
    g.every = 1000;
  }
  return g;
}

// The set-up: the liquid region [0, Lliq) holds the two reservoirs and the block [R, R + Lb)
// between them; the pushing slab sits in [-S, 0), the back-pressure slab in [Lliq, Lliq + S).
struct FloodScene {
  FloodGeometry g;
  double R, Lb, W, Lliq;
  std::vector<std::array<double, 3>> centres;  // of the grains
  BuiltSystem s;
  int source = 0, wall = 1, working = -1, push = -1, back = -1;

  // Depth into the solid: the deepest into any grain (minimum image across the flow).
  double depth(double x, double y, double z) const {
    if (x < R || x >= R + Lb) return -1e300;
    double best = -1e300;
    for (const auto& c : centres) {
      double dy = y - c[1], dz = z - c[2];
      dy -= W * std::round(dy / W);
      dz -= W * std::round(dz / W);
      const double dx = x - c[0];
      best = std::max(best, g.radius - std::sqrt(dx * dx + dy * dy + dz * dz));
    }
    return best;
  }
  bool in_block(double x) const { return x >= R && x < R + Lb; }
};

FloodScene build_flood_scene(const FloodGeometry& geometry, const ValidateOptions& o) {
  FloodScene f;
  const FloodGeometry& g = f.g = geometry;
  f.R = g.reservoir, f.Lb = g.block, f.W = g.width;
  f.Lliq = 2 * f.R + f.Lb;
  const double R = f.R, W = f.W, Lliq = f.Lliq;
  const double L[3] = {Lliq, W, W};
  // Whole grains inside the block (a cut through a grain would leave its hollow core open).
  const double span = f.Lb - 2 * g.radius - 1;
  for (int k = 0; k < g.grains; ++k)
    f.centres.push_back(
        {R + g.radius + 0.5 + sim::seeded_uniform(91, 1, static_cast<std::uint64_t>(k), 0) * span,
         sim::seeded_uniform(91, 1, static_cast<std::uint64_t>(k), 1) * W,
         sim::seeded_uniform(91, 1, static_cast<std::uint64_t>(k), 2) * W});
  const SolidDepth depth = [&f](double x, double y, double z) { return f.depth(x, y, z); };
  f.s = liquid_with_walls(L, {true, true, true}, depth, 1.5, 500, 93, o);
  sim::Model& m = f.s.model;
  m.types[0].name = "source";
  f.working = m.add_type({"working", false, {0, 0, 0}});
  for (int a = 0; a < m.ntypes(); ++a)
    for (int b = 0; b < m.ntypes(); ++b) m.set_pair(a, b, {kA, kB, kGamma});
  m.wall_model.wall_types = 1u << f.wall;
  sim::ParticleSet& p = f.s.particles;
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == f.source && p.x[i] < R) p.type[i] = f.working;
  // The pushing slab in [-S, 0), the back-pressure slab in [Lliq, Lliq + S), room behind it.
  const Pistons pistons =
      add_pistons(f.s, Lliq, g.slab, g.room, g.back_pressure + g.drive, g.back_pressure);
  f.push = pistons.push;
  f.back = pistons.back;
  m.virtual_walls.push_back({0, R, 1u << f.working, true, g.settle});
  return f;
}

struct Census {
  std::size_t source_in_block = 0, working_in_block = 0, beyond_skin = 0, behind_slabs = 0;
  double deepest = -1e300;
};

const double kSkin = std::cbrt(1.0 / kRho);  // as in no-penetration: one wall-particle spacing

// Where the fluid particles are now.
Census census(sim::Simulation& sim, const FloodScene& f) {
  Census c;
  const sim::ParticleSet p = sim.particles();
  const auto slabs = sim.rigid_slabs();
  // The fluid side of each slab: its mean position +- half its thickness.
  const double push_face = slabs[0].position - 0.5 * f.g.slab;
  const double back_face = slabs[1].position + 0.5 * f.g.slab;
  for (size_t i = 0; i < p.size(); ++i) {
    if (p.type[i] != f.source && p.type[i] != f.working) continue;
    const bool in_block = f.in_block(p.x[i]);
    c.source_in_block += p.type[i] == f.source && in_block;
    c.working_in_block += p.type[i] == f.working && in_block;
    const double d = f.depth(p.x[i], p.y[i], p.z[i]);
    c.deepest = std::max(c.deepest, d);
    c.beyond_skin += d > kSkin;
    c.behind_slabs += p.x[i] < push_face || p.x[i] > back_face;
  }
  return c;
}

// Reservoir pressures from the region stress, in the part of each reservoir at least 1 rc from
// its slab and 0.5 rc from the block (the slabs move, so the regions follow them).
bool reservoir_pressures(sim::Simulation& sim, const FloodScene& f, double& p_left,
                         double& p_right) {
  const auto slabs = sim.rigid_slabs();
  sim::RegionSelection left, right;
  left.type_mask = right.type_mask = (1u << f.source) | (1u << f.working);
  left.lo = {slabs[0].position + 0.5 * f.g.slab + 1, 0, 0};
  left.hi = {f.R - 0.5, f.W, f.W};
  right.lo = {f.R + f.Lb + 0.5, 0, 0};
  right.hi = {slabs[1].position - 0.5 * f.g.slab - 1, f.W, f.W};
  if (left.hi[0] - left.lo[0] < 1 || right.hi[0] - right.lo[0] < 1) return false;
  p_left = sim.region_stress(left).pressure();
  p_right = sim.region_stress(right).pressure();
  return true;
}

// What the run records for the verdicts.
struct FloodRecord {
  std::size_t source_in_block0 = 0;
  std::size_t worst_beyond = 0, worst_behind = 0, working_early = 0;
  double deepest = -1e300;
  std::vector<double> push_side, back_side;
  bool finite = true;
  double T = 0;
  Census last;
  double recovery() const {
    return 1.0 - static_cast<double>(last.source_in_block) / static_cast<double>(source_in_block0);
  }
};

FloodRecord run_flood(sim::Simulation& sim, const FloodScene& f, const ValidateOptions& o) {
  const FloodGeometry& g = f.g;
  const auto t0 = Clock::now();
  FloodRecord rec;
  const sim::ParticleSet start = sim.particles();
  std::size_t fluid = 0, walls = 0;
  for (size_t i = 0; i < start.size(); ++i) {
    rec.source_in_block0 += start.type[i] == f.source && f.in_block(start.x[i]);
    fluid += start.type[i] == f.source || start.type[i] == f.working;
    walls += start.type[i] == f.wall;
  }
  progress(o, "flooding-mini: " + std::to_string(start.size()) + " particles (" +
                  std::to_string(fluid) + " fluid, " + std::to_string(walls) + " wall in " +
                  std::to_string(g.grains) + " grains, " + std::to_string(rec.source_in_block0) +
                  " source particles in the block), slabs at " + fmt(g.back_pressure + g.drive) +
                  " and " + fmt(g.back_pressure) + "; settling " + std::to_string(g.settle) +
                  " steps behind the virtual wall, then flooding " + std::to_string(g.flood) +
                  " (" + sim.pass_name() + ", " + sim.backend_name() + ")");
  const std::uint64_t total = g.settle + g.flood;
  while (sim.step() < total) {
    const std::uint64_t chunk = std::min(g.every, total - sim.step());
    // Sample the reservoir pressures every 50 steps of the flooding stage.
    for (std::uint64_t done = 0; done < chunk; done += 50) {
      sim.run(std::min<std::uint64_t>(50, chunk - done));
      double pl = 0, pr = 0;
      if (sim.step() > g.settle + g.flood / 4 && reservoir_pressures(sim, f, pl, pr)) {
        rec.push_side.push_back(pl);  // after the start-up transient
        rec.back_side.push_back(pr);
      }
    }
    rec.last = census(sim, f);
    rec.T = sim.kinetic_temperature();
    rec.finite = rec.finite && std::isfinite(rec.T);
    rec.worst_beyond = std::max(rec.worst_beyond, rec.last.beyond_skin);
    rec.worst_behind = std::max(rec.worst_behind, rec.last.behind_slabs);
    rec.deepest = std::max(rec.deepest, rec.last.deepest);
    if (sim.step() <= g.settle)
      rec.working_early = std::max(rec.working_early, rec.last.working_in_block);
    const auto slabs = sim.rigid_slabs();
    progress(o, "  step " + std::to_string(sim.step()) + ": recovery " + fmt(rec.recovery(), 3) +
                    ", working in block " + std::to_string(rec.last.working_in_block) +
                    ", deeper than skin " + std::to_string(rec.last.beyond_skin) +
                    ", behind slabs " + std::to_string(rec.last.behind_slabs) + ", slabs at " +
                    fmt(slabs[0].position, 4) + " / " + fmt(slabs[1].position, 4) + ", T " +
                    fmt(rec.T, 4) + " (" + fmt(seconds_since(t0), 3) + " s)");
    if (!rec.finite) break;
  }
  return rec;
}

}  // namespace

CaseResult run_flooding_mini_case(const ValidateOptions& o) {
  CaseResult r;
  r.name = "flooding-mini";
  const FloodScene f = build_flood_scene(flood_geometry(o.size == CaseSize::Full), o);
  const FloodGeometry& g = f.g;
  auto sim = sim::make_simulation(f.s.model, f.s.box, f.s.particles, 0.01, o.sim);
  const FloodRecord rec = run_flood(*sim, f, o);
  const MeanWithError p_push = block_average(rec.push_side, 8),
                      p_back = block_average(rec.back_side, 8);
  r.quantities.push_back(
      judged("recovery: share of the block's source fluid that left it", rec.recovery(), 0, 0.20, 0,
             "issue: at least 20% of the source fluid leaves the pore block", Comparison::AtLeast));
  r.quantities.push_back(
      judged("fluid particles deeper than " + fmt(kSkin, 2) + " rc in a grain (worst check)",
             static_cast<double>(rec.worst_beyond), 0, 0, 0,
             "issue: no particle crosses a wall (skin as in no-penetration)", Comparison::AtMost));
  r.quantities.push_back(judged(
      "fluid particles behind a slab (worst check)", static_cast<double>(rec.worst_behind), 0, 0, 0,
      "issue: no particle crosses a wall (the pistons included)", Comparison::AtMost));
  r.quantities.push_back(
      judged("working-fluid particles in the block before the virtual wall "
             "goes (step " +
                 std::to_string(g.settle) + ")",
             static_cast<double>(rec.working_early), 0, 0, 0,
             "2020 paper: the virtual wall keeps the working fluid out", Comparison::AtMost));
  r.quantities.push_back(judged("kinetic temperature at the end", rec.finite ? rec.T : NAN, 0, 1.0,
                                0.1, "stability: thermostat at kBT = 1 (flow adds < 1%)"));
  // A slab moving at a steady speed is in force balance: the fluid pushes back on it with the
  // applied pressure, and the reservoir (too short for viscous losses to matter) has it too.
  for (auto [name, measured, applied] :
       {std::tuple{"working reservoir", p_push, g.back_pressure + g.drive},
        std::tuple{"source reservoir", p_back, g.back_pressure}})
    r.quantities.push_back(
        judged(std::string("pressure in the ") + name + " (region stress, time average)",
               measured.mean, measured.error, applied, 0.05 * applied + 2 * measured.error,
               "the pressure its slab applies; 5% + 2 errors (slab inertia, flow)"));
  r.notes.push_back("deepest fluid particle in a grain over the run " + fmt(rec.deepest, 3) +
                    " rc; " + std::to_string(sim->wall_corrections()) +
                    " wall-model corrections; source particles in the block " +
                    std::to_string(rec.source_in_block0) + " -> " +
                    std::to_string(rec.last.source_in_block) + "; working particles in it " +
                    std::to_string(rec.last.working_in_block));
  return r;
}

}  // namespace mesorock::pipeline
