// relperm-slit: two-phase co-flow in the slit of perm-slit, against the layered Poiseuille
// relative permeabilities (the standard test of the lattice-Boltzmann literature for kr codes).
//
// Two liquids W (wetting) and N (non-wetting), each the wall liquid of wall_liquid.h (A = -40,
// B = 25, rd = 0.75, gamma = 4.5), so their viscosities are equal (M = mu_N / mu_W = 1). They
// differ in the cross repulsion A_WN = -30 (immiscible: gamma_WN = 6.79 +- 0.1 in the
// interfacial-tension case at full size) and in the wall affinity: W keeps the liquid's A = -40
// with the frozen-liquid wall, N has A_SN = -20 (it does not wet). W starts as a film on each
// wall, N in the middle of the gap. Both feel the same body force g (the same pressure gradient).
// Why -30 and not a stronger -20 (gamma_WN 12.2): with -20, N flowed faster than the sharp-
// interface curve by 8-10% of kr_N at S = 0.19 (full size) and 11-16% at S = 0.29 (small), with
// -30 by 3-6% at S = 0.29 (small); kr_W did not change (docs/relperm.md).
//
// Reference. In the half gap y in [0, 1] (wall at 0, centre line at 1) with W in [0, S] and N in
// [S, 1], the stress is G (1 - y) whatever the fluid, and the flow rates relative to each fluid's
// single-phase rate at the same G are
//   kr_W = S^2 (3 - S) / 2,   kr_N = (1 - S) [3M/2 + (1 - S)^2 (1 - 3M/2)]   (M = 1: 1 - kr_W).
// S is the film's share of the half gap between the no-slip surface and the centre line: the
// film is a = S_cut h / 2 thick at the cut (S_cut: W's share of the fluid particles, the two
// liquids having one density), and the no-slip surface lies |b| = 0.069 rc inside the fluid
// (poiseuille-walls), so S = (a + b) / (h / 2 + b).
//
// Measured: kr of each phase = its momentum sum along the flow over that of the single-phase run
// (all W) with the same particles and force: with one number density, flow rates are momentum
// sums over that density. Errors from 10 block averages of each sum. The notes compare each
// run's velocity across the gap with the single-phase one (interface_slip).
#include <chrono>
#include <cmath>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/validation.h"
#include "pipeline/flow/wall_liquid.h"
#include "sim/observables.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
using namespace wall_liquid;

constexpr int kW = 0, kWall = 1, kN = 2;
constexpr double kASN = -20;
constexpr double kTolerance = 0.10;  // the issue: within 10% of the analytic curves

// Layered Poiseuille relative permeabilities (above) for a wetting share S of the half gap.
double kr_wetting(double S) {
  return S * S * (3 - S) / 2;
}
double kr_nonwetting(double S, double M) {
  return (1 - S) * (1.5 * M + (1 - S) * (1 - S) * (1 - 1.5 * M));
}

struct CoFlow {
  double wetting_share = 0;   // S_cut: W's share of the fluid particles
  MeanWithError momentum[2];  // sum of v_x over W and over N
  // Across the gap (bins of about 0.25 rc along z), summed over the samples: each liquid's count
  // and its sum of v_x.
  std::vector<double> count[2], vx[2];
  // The mean v_x of both liquids in bin b (0 where no fluid).
  double velocity(std::size_t b) const {
    const double c = count[0][b] + count[1][b];
    return c > 0 ? (vx[0][b] + vx[1][b]) / c : 0.0;
  }
  double w_share(std::size_t b) const {
    const double c = count[0][b] + count[1][b];
    return c > 0 ? count[0][b] / c : 0.0;
  }
  double temperature = 0;
  std::uint64_t corrections = 0;
  double seconds = 0;
};

// Runs `s` driven by g along x on both liquids; samples each liquid's profile across the gap
// every 10 steps after `settle` steps (bin sums: on the device for CUDA), whose sum over the bins
// is the liquid's momentum.
CoFlow measure_co_flow(BuiltSystem s, double g, std::uint64_t settle, std::uint64_t sample,
                       const std::string& label, const ValidateOptions& o) {
  for (int t : {kW, kN}) s.model.types[static_cast<size_t>(t)].body_force = {g, 0, 0};
  CoFlow r;
  std::size_t w = 0, n = 0;
  for (auto t : s.particles.type) {
    w += t == kW;
    n += t == kN;
  }
  r.wetting_share = static_cast<double>(w) / static_cast<double>(w + n);
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, o.sim);
  const auto t0 = Clock::now();
  progress(o, label + ": " + std::to_string(s.particles.size()) + " particles (W " +
                  std::to_string(w) + ", N " + std::to_string(n) + "), g = " + fmt(g, 3) + ", " +
                  std::to_string(settle) + " + " + std::to_string(sample) + " steps (" +
                  sim->backend_name() + ")");
  sim->run(settle);
  const int nz = std::max(1, static_cast<int>(std::lround(s.box.length(2) / 0.25)));
  sim::BinGrid bins[2];
  for (int k = 0; k < 2; ++k) {
    bins[k] = sim::BinGrid::profile(2, nz, {s.box.lo[0], s.box.lo[1], s.box.lo[2]},
                                    {s.box.hi[0], s.box.hi[1], s.box.hi[2]});
    bins[k].type_mask = 1u << (k == 0 ? kW : kN);
    r.count[k].assign(static_cast<std::size_t>(nz), 0.0);
    r.vx[k].assign(static_cast<std::size_t>(nz), 0.0);
  }
  std::vector<double> sums[2], temperature;
  const std::uint64_t every = 10;
  for (std::uint64_t k = 0; k < sample / every; ++k) {
    sim->run(every);
    for (int p = 0; p < 2; ++p) {
      const std::vector<double> b = sim->bin_sums(bins[p]);
      double v = 0;
      for (std::size_t z = 0; z < r.count[p].size(); ++z) {
        r.count[p][z] += b[z * sim::kBinFields + sim::kBinCount];
        r.vx[p][z] += b[z * sim::kBinFields + sim::kBinVx];
        v += b[z * sim::kBinFields + sim::kBinVx];
      }
      if (!std::isfinite(v))
        throw NumericalError(label + ": momentum is not finite at step " +
                             std::to_string(sim->step()));
      sums[p].push_back(v);
    }
    if (k % 10 == 0) temperature.push_back(sim->kinetic_temperature());
  }
  for (int p = 0; p < 2; ++p) r.momentum[p] = block_average(sums[p], 10);
  r.temperature = block_average(temperature, 0).mean;
  r.corrections = sim->wall_corrections();
  r.seconds = seconds_since(t0);
  progress(o, label + ": momentum W " + fmt(r.momentum[0].mean) + " +- " +
                  fmt(r.momentum[0].error, 2) + ", N " + fmt(r.momentum[1].mean) + " +- " +
                  fmt(r.momentum[1].error, 2) + ", T " + fmt(r.temperature, 4) + " (" +
                  fmt(r.seconds, 3) + " s)");
  return r;
}

// Where the two-phase flow departs from the single-phase one at the same force: the mean of
// u(z) - u_1(z) over the bins that hold W alone (over 95% of their fluid), over those that hold N
// alone, and the single-phase velocity in the latter. A slip at the W-N interface shows as a
// departure in the N core only.
std::string interface_slip(const CoFlow& f, const CoFlow& single) {
  double film = 0, core = 0, core_u1 = 0;
  int nfilm = 0, ncore = 0;
  for (std::size_t b = 0; b < f.count[0].size(); ++b) {
    const double c = f.count[0][b] + f.count[1][b];
    if (!(c > 0) || !(single.count[0][b] > 0)) continue;
    const double du = f.velocity(b) - single.velocity(b);
    if (f.w_share(b) > 0.95) {
      film += du;
      ++nfilm;
    } else if (f.w_share(b) < 0.05) {
      core += du;
      core_u1 += single.velocity(b);
      ++ncore;
    }
  }
  return "films " + (nfilm > 0 ? fmt(film / nfilm, 3) : std::string("-")) + ", core " +
         (ncore > 0 ? fmt(core / ncore, 3) + " (u_1 " + fmt(core_u1 / ncore, 3) + ")"
                    : std::string("-"));
}

}  // namespace

CaseResult run_relperm_slit_case(const ValidateOptions& o) {
  CaseResult r;
  r.name = "relperm-slit";
  const bool full = o.size == CaseSize::Full;
  const double h = full ? 16 : 10, Lxy = full ? 10 : 5;
  const std::uint64_t settle = full ? 3000 : 1000, sample = full ? 60000 : 15000;
  const std::vector<double> shares =
      full ? std::vector<double>{0.2, 0.35, 0.5, 0.65, 0.8} : std::vector<double>{0.3, 0.5, 0.7};
  Slit slit = make_slit(h, Lxy, 91, o);
  // The start on the no-slip profile (perm-slit's), which is also the two-phase one at M = 1.
  const double g = slit.newtonian_force(), h_eff = slit.h_eff;
  slit.start_on_profile(g);
  BuiltSystem& base = slit.system;
  const double z0 = slit.z0, z1 = slit.z1;
  if (add_second_liquid(base.model, kAWN, kWall, kASN) != kN)
    throw ConfigError("relperm-slit: the second liquid is not type 2");
  std::uint64_t seed = 92 + o.seed_offset;
  base.model.seed = seed++;
  const CoFlow single = measure_co_flow(base, g, settle, sample, "relperm-slit single phase", o);
  const MeanWithError& q0 = single.momentum[0];
  std::ostringstream table, profiles;
  table << "S_cut -> S (hydrodynamic): kr_W, kr_N (analytic):";
  profiles << "velocity across the gap against the single-phase run's, mean of u - u_1 where "
              "the bins hold W alone (the films), N alone (the core), and the core's u_1:";
  for (double share : shares) {
    BuiltSystem s = base;
    s.model.seed = seed++;
    // W within a = share h / 2 of either cut surface, N in the middle.
    const double a = share * h / 2;
    for (size_t i = 0; i < s.particles.size(); ++i)
      if (s.particles.type[i] == kW && std::min(s.particles.z[i] - z0, z1 - s.particles.z[i]) > a)
        s.particles.type[i] = kN;
    const CoFlow f =
        measure_co_flow(s, g, settle, sample, "relperm-slit S_cut = " + fmt(share, 3), o);
    const double S = (f.wetting_share * h / 2 + kSlipLength) / (h / 2 + kSlipLength);
    const MeanWithError kw = ratio(f.momentum[0], q0), kn = ratio(f.momentum[1], q0);
    const double rw = kr_wetting(S), rn = kr_nonwetting(S, 1.0);
    const std::string at = " at S = " + fmt(S, 3);
    const std::string src =
        "layered slit Poiseuille, M = 1: kr_W = S^2 (3 - S) / 2, kr_N = 1 - kr_W";
    const std::string tol = full ? "; issue: within 10%" : "; issue: within 10% (+ 2 sigma small)";
    auto tolerance = [&](double ref, double err) {
      return kTolerance * ref + (full ? 0.0 : 2 * err);
    };
    r.quantities.push_back(
        judged("kr_W" + at, kw.mean, kw.error, rw, tolerance(rw, kw.error), src + tol));
    r.quantities.push_back(
        judged("kr_N" + at, kn.mean, kn.error, rn, tolerance(rn, kn.error), src + tol));
    profiles << " S_cut " << fmt(f.wetting_share, 3) << ": " << interface_slip(f, single) << ";";
    table << " " << fmt(f.wetting_share, 3) << " -> " << fmt(S, 3) << ": " << fmt(kw.mean, 3)
          << " +- " << fmt(kw.error, 2) << " (" << fmt(rw, 3) << "), " << fmt(kn.mean, 3) << " +- "
          << fmt(kn.error, 2) << " (" << fmt(rn, 3) << "), sum " << fmt(kw.mean + kn.mean, 3)
          << ", T " << fmt(f.temperature, 4) << ";";
  }
  r.notes.push_back(table.str());
  r.notes.push_back(profiles.str());
  r.notes.push_back("slit of cut width " + fmt(h, 3) + " rc (hydrodynamic " + fmt(h_eff, 4) +
                    "), " + fmt(Lxy, 3) + " x " + fmt(Lxy, 3) + " rc, walls of frozen liquid " +
                    fmt(kWallThickness, 3) +
                    " rc thick with the wall model; W and N: the wall liquid (A = -40, B = 25, rd "
                    "= 0.75, gamma = "
                    "4.5), A_WN = " +
                    fmt(kAWN, 3) + ", A_SW = -40, A_SN = " + fmt(kASN, 3) + "; g = " + fmt(g, 4) +
                    " on both; " + std::to_string(settle) + " + " + std::to_string(sample) +
                    " steps per run; single phase: momentum " + fmt(q0.mean) + " +- " +
                    fmt(q0.error, 2) + ", T " + fmt(single.temperature, 4));
  return r;
}

}  // namespace mesorock::pipeline
