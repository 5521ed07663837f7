// drainage-slit: capillary entry under stepped pressure, the machinery of `rockflow pc`
// (drainage.h) against Young-Laplace.
//
// A slit of cut width h (walls of frozen W liquid with the wall model, 1.5 rc thick, periodic
// across z) runs through a block of length Lb along x. Before the block, a reservoir of N pushed
// by a slab; after it, a reservoir of W held by a back-pressure slab at P_back = 60 (about the
// liquid's pressure at its density 7), and the membrane (a virtual wall at the block's outlet
// face that N cannot pass). W and N are the liquid of wall_liquid.h, A_WN = -30; the walls meet W
// with the rock layout's A_SW = -18 and N with A_SN = -8. The capillary pressure Pc = P_push -
// P_back rises level by level; N enters the slit once Pc exceeds the entry pressure of a slit,
//   Pc_entry = 2 gamma_WN cos(theta) / h     (Young-Laplace, a cylindrical meniscus),
// with gamma_WN and theta from the calibration cases: gamma_WN = 9.998 +- 0.051 (flat interface at
// density 7) and theta = 42.0 +- 0.6 degrees at A_SN = -8 (docs/calibration/
// contact_angle_WN_A_SN.csv; both from `rockflow validate wn-contact-angle --size full`, H200,
// 2026-12-04). Those come from the pressure jump across a static plug in the same slit; this case
// checks what `rockflow pc` adds: that pressures applied by the pistons through the reservoirs
// drive N into a pore exactly when Young-Laplace says, and not before.
//
// The pressure then falls again (imbibition) and W comes back in, at a lower Pc than N went in:
// the hysteresis loop of a real drainage-imbibition cycle.
//
// Judged: the entry pressure, bracketed by the last drainage level at which S_w in the block stays
// at or above 0.4 and the first below it, within 10% of Young-Laplace (the tolerance; the
// levels sit at 0.9 and 1.1 of it, so a bracket on the wrong side of either fails); W re-entering
// on the imbibition branch no higher than the last drainage level N did not enter at; S_w back
// above 0.9 at Pc = 0; no N beyond the membrane; the temperature.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/flow/drainage.h"
#include "pipeline/flow/validation.h"
#include "pipeline/flow/wall_liquid.h"

namespace mesorock::pipeline {

namespace {

using namespace wall_liquid;

// The calibration (docs/calibration/contact_angle_WN_A_SN.csv, wn-contact-angle full size).
constexpr double kGammaWN = 9.99844, kGammaWNError = 0.0512276;
constexpr double kCosTheta = 0.742732, kCosThetaError = 0.00759127;  // A_SN = -8 at A_SW = -18
constexpr double kASW = -18, kASN = -8;
constexpr double kBackPressure = 60;  // about the liquid's pressure at density 7 (Warren: 60.2)
// A level counts as invaded below this S_w: N through the slit leaves W films only (S_w 0.1 to
// 0.2); a meniscus held at the mouth bulges into the 4 rc slit and leaves S_w near 0.65 (small).
constexpr double kInvaded = 0.4;

struct DrainageSlitGeometry {
  double h = 8;          // cut width, as in the calibration
  double width = 4;      // along y (periodic; the meniscus is a cylinder along y)
  double block = 4;      // slit length along x
  double reservoir = 6;  // each liquid reservoir along x
  double slab = 1, room = 6;
  // Pc / Pc_entry: the drainage branch (rising), then the imbibition branch (falling).
  std::vector<double> levels{0, 0.9, 1.1, 1.3, 0.9, 0.7, 0.5, 0};
  std::uint64_t block_steps = 500, max_level_steps = 25000;
  int window = 2, measure_blocks = 3;
};

DrainageSlitGeometry drainage_slit_geometry(bool full) {
  DrainageSlitGeometry g;
  if (!full) return g;
  g.width = 12;
  g.block = 8;
  g.reservoir = 10;
  g.room = 10;
  g.levels = {0, 0.5, 0.8, 0.9, 0.95, 1.05, 1.1, 1.2, 1.4, 1.1, 0.9, 0.8, 0.7, 0.6, 0.5, 0.3, 0};
  g.block_steps = 1000;
  g.max_level_steps = 60000;
  g.window = 3;
  g.measure_blocks = 5;
  return g;
}

// The slit's solid: the band |z| < w/2 about z = 0 (periodic, period h + w), inside the block
// [R, R + Lb) only; the reservoirs are open. Depth into it, <= 0 in the pore.
struct SlitBlock {
  double R = 0, Lb = 0, h = 0, w = kWallThickness;
  double depth(double x, double /*y*/, double z) const {
    const double period = h + w;
    z -= period * std::floor(z / period);
    if (x < R || x >= R + Lb) return -1e300;
    const double face_lo = w / 2, face_hi = h + w / 2;  // the slit's two faces
    if (z >= face_lo && z <= face_hi) return -std::min(z - face_lo, face_hi - z);
    const double dz = z < face_lo ? face_lo - z : z - face_hi;
    return std::min({dz, x - R, R + Lb - x});
  }
};

}  // namespace

CaseResult run_drainage_slit_case(const ValidateOptions& o) {
  CaseResult r;
  r.name = "drainage-slit";
  const bool full = o.size == CaseSize::Full;
  const DrainageSlitGeometry g = drainage_slit_geometry(full);
  SlitBlock solid{g.reservoir, g.block, g.h};
  const double Lliq = 2 * g.reservoir + g.block;
  const double L[3] = {Lliq, g.width, g.h + solid.w};
  BuiltSystem s = liquid_with_walls(
      L, {true, true, true},
      [&solid](double x, double y, double z) { return solid.depth(x, y, z); }, kWallThickness, 500,
      141, o);
  constexpr int kW = 0, kWall = 1;
  s.model.set_pair(kW, kWall, {kASW, kB, kGamma});
  const int n_type = add_second_liquid(s.model, kAWN, kWall, kASN);
  s.model.seed = 143 + o.seed_offset;
  for (size_t i = 0; i < s.particles.size(); ++i)
    if (s.particles.type[i] == kW && s.particles.x[i] < g.reservoir) s.particles.type[i] = n_type;
  add_pistons(s, Lliq, g.slab, g.room, kBackPressure, kBackPressure);
  DrainageCell cell;
  cell.axis = 0;
  cell.block_lo = g.reservoir;
  cell.block_hi = g.reservoir + g.block;
  cell.wetting = kW;
  cell.nonwetting = n_type;
  cell.slab_thickness = g.slab;
  s.model.virtual_walls.push_back(drainage_membrane(cell));
  // N stays out of the block while the pistons settle (the liquid was equilibrated periodic).
  s.model.virtual_walls.push_back({0, cell.block_lo, 1u << n_type, true, 500});

  const double entry = 2 * kGammaWN * kCosTheta / g.h;  // Young-Laplace
  const double entry_error =
      entry * std::hypot(kGammaWNError / kGammaWN, kCosThetaError / kCosTheta);
  DrainageOptions d;
  for (double f : g.levels) d.pressures.push_back(f * entry);
  d.back_pressure = kBackPressure;
  d.block_steps = g.block_steps;
  d.window = g.window;
  d.tolerance = 0.02;  // the slit drains from about 0.65 to 0.1 at once
  d.measure_blocks = g.measure_blocks;
  d.max_level_steps = g.max_level_steps;
  d.sim = o.sim;
  std::size_t fluid = 0;
  for (auto t : s.particles.type) fluid += t == kW || t == n_type;
  progress(o, "drainage-slit: " + std::to_string(s.particles.size()) + " particles (" +
                  std::to_string(fluid) + " fluid), slit h = " + fmt(g.h, 3) + " rc, " +
                  fmt(g.block, 3) + " rc long; Young-Laplace entry " + fmt(entry, 4) + "; " +
                  std::to_string(d.pressures.size()) + " levels");
  const auto t0 = std::chrono::steady_clock::now();
  const DrainageResult res = run_drainage(s.model, s.box, s.particles, cell, d, false);
  std::ostringstream levels;
  levels << "Pc -> S_w (measured Pc, steps):";
  for (const DrainageLevel& l : res.levels) {
    levels << " " << fmt(l.pc_applied, 4) << " -> " << fmt(l.saturation.mean, 3) << " +- "
           << fmt(l.saturation.error, 2) << " (" << fmt(l.pc_measured.mean, 3) << " +- "
           << fmt(l.pc_measured.error, 2) << ", " << l.steps << (l.steady ? "" : ", NOT steady")
           << ");";
    progress(o, "  Pc " + fmt(l.pc_applied, 4) + ": S_w " + fmt(l.saturation.mean, 3) +
                    ", measured Pc " + fmt(l.pc_measured.mean, 3) + ", " + std::to_string(l.steps) +
                    " steps (" + fmt(seconds_since(t0), 3) + " s)");
  }
  const EntryPressure e = entry_pressure(res.levels, kInvaded);
  const EntryPressure back = reentry_pressure(res.levels, kInvaded);
  r.quantities.push_back(judged(
      "drainage: N enters the slit between Pc = " + fmt(e.lower, 4) + " and " + fmt(e.upper, 4),
      e.found ? e.estimate() : NAN, e.half_width(), entry, 0.10 * entry,
      "Young-Laplace 2 gamma_WN cos(theta) / h = " + fmt(entry, 4) + " +- " + fmt(entry_error, 2) +
          ", gamma_WN and theta from wn-contact-angle (full); issue: within 10%"));
  // Hysteresis: W comes back only below the pressure at which N went in (a loop, not a line; a
  // pressure offset of the pistons would move both branches alike).
  r.quantities.push_back(
      judged("imbibition: W re-enters between Pc = " + fmt(back.lower, 4) + " and " +
                 fmt(back.upper, 4) + " (upper end)",
             back.found ? back.upper : NAN, 0, e.lower, 0,
             "at most the pressure below which N had not entered (the loop's drainage branch)",
             Comparison::AtMost));
  const double refilled = res.levels.empty() ? NAN : res.levels.back().saturation.mean;
  r.quantities.push_back(judged("S_w back at Pc = 0 after the loop", refilled, 0, 0.9, 0,
                                "W refills the slit once N is no longer pushed",
                                Comparison::AtLeast));
  std::size_t beyond = 0;
  const sim::ParticleSet& end = res.end_state();
  for (size_t i = 0; i < end.size(); ++i)
    beyond += end.type[i] == n_type && end.x[i] >= cell.block_hi;
  r.quantities.push_back(judged("N particles beyond the membrane at the end",
                                static_cast<double>(beyond), 0, 0, 0,
                                "the membrane keeps N in the block", Comparison::AtMost));
  std::size_t behind = 0;
  for (const DrainageLevel& l : res.levels) behind = std::max(behind, l.behind_slabs);
  r.quantities.push_back(judged(
      "fluid particles behind a slab (worst block)", static_cast<double>(behind), 0, 0, 0,
      "the pistons hold the fluid (else they do not apply their pressure)", Comparison::AtMost));
  const double T = res.levels.empty() ? NAN : res.levels.back().temperature;
  r.quantities.push_back(
      judged("kinetic temperature at the end", T, 0, 1.0, 0.1, "stability: thermostat at kBT = 1"));
  r.notes.push_back(levels.str());
  r.notes.push_back("S_w = W / (W + N) in the block, averaged over " +
                    std::to_string(g.measure_blocks) + " blocks of " +
                    std::to_string(g.block_steps) +
                    " steps once steady; measured Pc: region "
                    "stress of the N reservoir minus the W reservoir's; A_SW " +
                    fmt(kASW, 3) + ", A_SN " + fmt(kASN, 3) + ", A_WN " + fmt(kAWN, 3) +
                    (res.inlet_used_up ? "; stopped: the N reservoir was used up" : ""));
  return r;
}

}  // namespace mesorock::pipeline
