// The wall issue's validation cases for the boundary model of Li et al. 2018 (sim/wall_model.h):
// poiseuille-walls (no slip, bulk viscosity, no density or temperature spike at the wall) and
// no-penetration (a body-force-driven fluid in a synthetic grain pack keeps out of the solid).
//
// Walls in both cases are frozen liquid: a periodic box of the liquid is equilibrated, then the
// particles inside the solid within the wall thickness freeze in place and the rest of the solid
// is emptied. This is the packing of Liu et al. that the 2020 paper describes, affordable here
// because the boxes are small; it gives the wall the liquid's own structure and density, which is
// what the model's no-slip derivation assumes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/flow/statistics.h"
#include "pipeline/flow/systems.h"
#include "pipeline/flow/validation.h"
#include "pipeline/flow/wall_liquid.h"
#include "sim/init.h"
#include "sim/observables.h"

namespace mesorock::pipeline {

using Clock = std::chrono::steady_clock;

using namespace wall_liquid;

namespace {

// --------------------------------------------------------------------------------------------
// poiseuille-walls: body-force flow between two flat walls (surfaces at z = w and z = Lz - w).
// Stokes flow under a uniform force g: u(z) = rho g / (2 eta) (z - z0)(z1 - z); a fit
// u = c0 + c1 (z - zc) + c2 (z - zc)^2 over the channel gives eta = -rho g / (2 c2) and the zeros
// z0, z1 of the parabola; the slip length is how far beyond each wall surface the parabola
// reaches zero (0 = no slip; positive = slip).

struct ChannelResult {
  double eta = 0, eta_error = 0;
  double slip_low = 0, slip_high = 0, slip_error = 0;
  double bulk_density = 0, wall_density = 0, wall_density_error = 0;
  double bulk_temperature = 0, wall_temperature = 0, wall_temperature_error = 0;
  double u_max = 0;
  std::uint64_t corrections = 0;
  std::vector<double> z, u, u_err, rho, temperature;
};

// The density next to each wall (the bins within 0.5 rc of its surface at w and Lz - w) in each
// of the 2 x 2 columns of `patches`: 8 values.
std::vector<double> wall_patch_densities(const sim::BinnedAverage& patches, int bins, double width,
                                         double w, double Lz) {
  const auto rho = patches.density();
  std::vector<double> per_patch;
  for (int side = 0; side < 2; ++side)
    for (int column = 0; column < 4; ++column) {
      double sum = 0;
      int count = 0;
      for (int b = 0; b < bins; ++b) {
        const double z = (b + 0.5) * width;
        const bool next = side == 0 ? (z > w && z < w + 0.5) : (z < Lz - w && z > Lz - w - 0.5);
        if (!next) continue;
        sum += rho.mean[static_cast<size_t>(b) * 4 + static_cast<size_t>(column)];
        ++count;
      }
      per_patch.push_back(count > 0 ? sum / count : 0.0);
    }
  return per_patch;
}

ChannelResult measure_channel(const ValidateOptions& o, std::uint64_t seed) {
  const bool full = o.size == CaseSize::Full;
  const double w = 1.5;             // wall thickness, the wall surface is at z = w
  const double H = full ? 16 : 10;  // channel height between the surfaces
  const double Lxy = full ? 10 : 6;
  const double L[3] = {Lxy, Lxy, H + 2 * w};
  // Peak shear rate rho g H / (2 eta) = 0.2 (linear response, see the viscosity case).
  const double g = 0.2 * 2 * kBulkViscosity / (kRho * H);
  const std::uint64_t equilibrate = full ? 3000 : 2000, sample = full ? 60000 : 16000;
  const std::uint64_t every = 10;
  BuiltSystem s = liquid_with_walls(
      L, {true, true, false},
      [&](double, double, double z) { return std::max(w - z, z - (L[2] - w)); }, w, 500, seed, o);
  s.model.types[0].body_force = {g, 0, 0};
  // Start from the no-slip profile so that the flow needs no viscous start-up time (H^2 / nu).
  for (size_t i = 0; i < s.particles.size(); ++i)
    if (s.particles.type[i] == 0) {
      const double z = s.particles.z[i] - w;
      s.particles.vx[i] += kRho * g / (2 * kBulkViscosity) * z * (H - z);
    }
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, o.sim);
  const auto t0 = Clock::now();
  progress(o, "poiseuille-walls: " + std::to_string(s.particles.size()) + " particles, channel " +
                  fmt(H) + " rc, g = " + fmt(g, 3) + ", equilibrating " +
                  std::to_string(equilibrate) + " steps (" + sim->pass_name() + ", " +
                  sim->backend_name() + ")");
  sim->run(equilibrate);
  const int bins = static_cast<int>(L[2] * 4);  // 0.25 rc bins
  sim::BinGrid grid = sim::BinGrid::profile(2, bins, s.box.lo, s.box.hi);
  grid.type_mask = 1u;  // fluid only
  sim::BinnedAverage profile(grid);
  // The same bins split into 2 x 2 columns: the density next to the wall per patch of wall.
  sim::BinGrid patch_grid = grid;
  patch_grid.cells = {2, 2, bins};
  sim::BinnedAverage patches(patch_grid);
  constexpr int kBlocks = 16;
  const std::uint64_t samples = sample / every, per_block = samples / kBlocks;
  std::vector<std::vector<double>> block_sums(kBlocks);
  for (std::uint64_t k = 0; k < per_block * kBlocks; ++k) {
    sim->run(every);
    const auto sums = sim->bin_sums(grid);
    profile.add(sums);
    patches.add(sim->bin_sums(patch_grid));
    auto& blk = block_sums[static_cast<size_t>(k / per_block)];
    if (blk.empty()) blk.assign(sums.size(), 0.0);
    for (size_t q = 0; q < sums.size(); ++q) blk[q] += sums[q];
  }
  const double width = L[2] / bins;
  const double zc = 0.5 * L[2];
  // Fit over the channel away from the first 0.5 rc at each wall (where the fluid's structure,
  // not the Stokes solution, shapes the profile); the zeros are extrapolated to the walls.
  auto fit_of = [&](const std::vector<double>& u) {
    std::vector<double> zz, uu;
    for (int b = 0; b < bins; ++b) {
      const double z = (b + 0.5) * width;
      if (z < w + 0.5 || z > L[2] - w - 0.5) continue;
      zz.push_back(z);
      uu.push_back(u[static_cast<size_t>(b)]);
    }
    return fit_parabola(zz, uu, {}, zc);
  };
  struct Derived {
    double eta, slip_low, slip_high;
  };
  auto derive = [&](const ParabolaFit& f, double rho) {
    // u = c0 + c1 d + c2 d^2 (d = z - zc) has zeros at d = (-c1 -+ sqrt(c1^2 - 4 c0 c2)) / 2c2.
    const double disc = std::sqrt(std::max(0.0, f.c1 * f.c1 - 4 * f.c0 * f.c2));
    const double d_a = (-f.c1 + disc) / (2 * f.c2), d_b = (-f.c1 - disc) / (2 * f.c2);
    const double z0 = zc + std::min(d_a, d_b), z1 = zc + std::max(d_a, d_b);
    return Derived{-rho * g / (2 * f.c2), w - z0, z1 - (L[2] - w)};
  };
  ChannelResult r;
  const auto u = profile.velocity(0), rho = profile.density(), T = profile.temperature();
  // Bulk: the middle third of the channel.
  double rsum = 0, tsum = 0;
  int nmid = 0;
  for (int b = 0; b < bins; ++b) {
    const double z = (b + 0.5) * width;
    if (std::abs(z - zc) > H / 6) continue;
    rsum += rho.mean[static_cast<size_t>(b)];
    tsum += T.mean[static_cast<size_t>(b)];
    ++nmid;
  }
  r.bulk_density = rsum / nmid;
  r.bulk_temperature = tsum / nmid;
  const Derived d = derive(fit_of(u.mean), r.bulk_density);
  r.eta = d.eta;
  r.slip_low = d.slip_low;
  r.slip_high = d.slip_high;
  std::vector<double> etas, slips;
  for (const auto& blk : block_sums) {
    std::vector<double> ub(static_cast<size_t>(bins));
    for (int b = 0; b < bins; ++b) {
      const double n = blk[static_cast<size_t>(b) * sim::kBinFields + sim::kBinCount];
      ub[static_cast<size_t>(b)] =
          n > 0 ? blk[static_cast<size_t>(b) * sim::kBinFields + sim::kBinVx] / n : 0.0;
    }
    const Derived db = derive(fit_of(ub), r.bulk_density);
    etas.push_back(db.eta);
    slips.push_back(0.5 * (db.slip_low + db.slip_high));
  }
  r.eta_error = block_average(etas, 0).error;
  r.slip_error = block_average(slips, 0).error;
  // Next to the wall: the fluid layer 0.5 rc thick on each surface (two bins per side, pooled).
  double wr = 0, wre = 0, wt = 0, wte = 0;
  int nw = 0;
  for (int b = 0; b < bins; ++b) {
    const double z = (b + 0.5) * width;
    const bool next_to_wall = (z > w && z < w + 0.5) || (z < L[2] - w && z > L[2] - w - 0.5);
    if (!next_to_wall) continue;
    wr += rho.mean[static_cast<size_t>(b)];
    wre += rho.error[static_cast<size_t>(b)] * rho.error[static_cast<size_t>(b)];
    wt += T.mean[static_cast<size_t>(b)];
    wte += T.error[static_cast<size_t>(b)] * T.error[static_cast<size_t>(b)];
    ++nw;
  }
  r.wall_density = wr / nw;
  // Its error: the wall particles are frozen in one random arrangement per seed, which thins
  // the fluid next to them more or less, and the bins' block errors, which see only the thermal
  // noise, came out 7 times below the spread over seeds at the small size (docs/validation.md,
  // "How firm the small cases are"). The 8 patches (2 x 2 per wall) sample that disorder: the
  // error is the larger of the bins' and the patches' standard error.
  const std::vector<double> per_patch = wall_patch_densities(patches, bins, width, w, L[2]);
  r.wall_density_error = std::max(std::sqrt(wre) / nw, block_average(per_patch, 0).error);
  r.wall_temperature = wt / nw;
  r.wall_temperature_error = std::sqrt(wte) / nw;
  for (int b = 0; b < bins; ++b) {
    r.z.push_back((b + 0.5) * width);
    r.u.push_back(u.mean[static_cast<size_t>(b)]);
    r.u_err.push_back(u.error[static_cast<size_t>(b)]);
    r.rho.push_back(rho.mean[static_cast<size_t>(b)]);
    r.temperature.push_back(T.mean[static_cast<size_t>(b)]);
    r.u_max = std::max(r.u_max, u.mean[static_cast<size_t>(b)]);
  }
  r.corrections = sim->wall_corrections();
  progress(o, "poiseuille-walls: eta = " + fmt(r.eta) + " +- " + fmt(r.eta_error, 2) +
                  ", slip lengths " + fmt(r.slip_low, 3) + " / " + fmt(r.slip_high, 3) + " +- " +
                  fmt(r.slip_error, 2) + ", density wall/bulk " + fmt(r.wall_density, 4) + " / " +
                  fmt(r.bulk_density, 4) + ", T wall/bulk " + fmt(r.wall_temperature, 4) + " / " +
                  fmt(r.bulk_temperature, 4) + ", corrections " + std::to_string(r.corrections) +
                  " (" + fmt(seconds_since(t0), 3) + " s)");
  return r;
}

}  // namespace

CaseResult run_poiseuille_walls_case(const ValidateOptions& o) {
  CaseResult r;
  r.name = "poiseuille-walls";
  const ChannelResult c = measure_channel(o, 61);
  const double slip = 0.5 * (c.slip_low + c.slip_high);
  r.quantities.push_back(judged("slip length (mean of both walls, rc)", slip, c.slip_error, 0.3, 0,
                                "issue: under 0.3 rc (Li et al. 2018: no slip)",
                                Comparison::AtMost));
  r.quantities.push_back(judged("slip length, magnitude (rc)", std::abs(slip), c.slip_error, 0.3, 0,
                                "issue: |slip| under 0.3 rc", Comparison::AtMost));
  // 5% of the bulk value, widened by two combined standard errors at the small size, where the
  // channel's own statistical error is comparable to 5%.
  const double eta_sigma = std::hypot(c.eta_error, kBulkViscosityError);
  const double eta_tol = 0.05 * kBulkViscosity + (o.size == CaseSize::Small ? 2 * eta_sigma : 0.0);
  r.quantities.push_back(
      judged("viscosity between walls", c.eta, c.eta_error, kBulkViscosity, eta_tol,
             "bulk `viscosity` case, full size: 6.97 +- 0.057; issue: within 5%" +
                 std::string(o.size == CaseSize::Small ? " (+ 2 sigma at the small size)" : "")));
  // 5%, widened by two standard errors at the small size, as the viscosity: the wall model thins
  // the first layer by about 4.6% (full size), and over 28 seeds the small channel's value
  // spread by 0.008 about 0.955 (docs/validation.md).
  const double rho_sigma = c.wall_density_error / c.bulk_density;
  r.quantities.push_back(
      judged("fluid density next to the wall / bulk", c.wall_density / c.bulk_density, rho_sigma,
             1.0, 0.05 + (o.size == CaseSize::Small ? 2 * rho_sigma : 0.0),
             "issue: within 5% of bulk (first 0.5 rc from each wall surface)" +
                 std::string(o.size == CaseSize::Small ? " (+ 2 sigma at the small size)" : "")));
  r.quantities.push_back(judged("temperature next to the wall / bulk",
                                c.wall_temperature / c.bulk_temperature,
                                c.wall_temperature_error / c.bulk_temperature, 1.0, 0.05,
                                "issue: within 5% of bulk (first 0.5 rc from each wall surface)"));
  r.notes.push_back("slip lengths " + fmt(c.slip_low, 3) + " (lower wall), " + fmt(c.slip_high, 3) +
                    " (upper wall); peak velocity " + fmt(c.u_max, 3) + "; bulk density " +
                    fmt(c.bulk_density, 4) + ", bulk temperature " + fmt(c.bulk_temperature, 4) +
                    "; " + std::to_string(c.corrections) + " wall-model corrections");
  std::ostringstream prof;
  prof << "profile z: u, rho, T ->";
  for (size_t k = 0; k < c.z.size(); k += 2)
    prof << " " << fmt(c.z[k], 3) << ": " << fmt(c.u[k], 3) << ", " << fmt(c.rho[k], 3) << ", "
         << fmt(c.temperature[k], 3) << ";";
  r.notes.push_back(prof.str());
  return r;
}

// --------------------------------------------------------------------------------------------
// no-penetration: fluid in a synthetic grain pack (overlapping spheres in a periodic box, the
// solid), driven along x by a body force; frozen-liquid walls 1.5 rc thick line the grains. No
// fluid particle may get deeper into the solid than a skin of half the wall-particle spacing;
// the report gives the deepest one, and a run without the model shows the leak it prevents.

namespace {
struct Grain {
  double c[3];
  double r;
};
}  // namespace

CaseResult run_no_penetration_case(const ValidateOptions& o) {
  CaseResult r;
  r.name = "no-penetration";
  const bool full = o.size == CaseSize::Full;
  // Small: 9^3 rc with 3 grains of radius 2.5 (about 3,800 particles); full: 24^3 with 16 grains
  // of radius 4 (about 70,000). Both run the 10,000 steps.
  const double Ledge = full ? 24 : 9;
  const double L[3] = {Ledge, Ledge, Ledge};
  const int ngrains = full ? 16 : 3;
  const double radius = full ? 4.0 : 2.5;
  const std::uint64_t steps = 10000;
  const double g = 0.05;
  std::vector<Grain> grains;
  for (int k = 0; k < ngrains; ++k) {
    Grain gr;
    for (int a = 0; a < 3; ++a)
      gr.c[a] = sim::seeded_uniform(71, 3, static_cast<std::uint64_t>(k), a) * L[a];
    gr.r = radius;
    grains.push_back(gr);
  }
  // Depth into the solid: the largest (radius - distance) over the grains (minimum image).
  const SolidDepth depth = [&](double x, double y, double z) {
    double best = -1e300;
    const double p[3] = {x, y, z};
    for (const Grain& gr : grains) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        double d = p[a] - gr.c[a];
        d -= L[a] * std::round(d / L[a]);
        d2 += d * d;
      }
      best = std::max(best, gr.r - std::sqrt(d2));
    }
    return best;
  };
  BuiltSystem s = liquid_with_walls(L, {true, true, true}, depth, 1.5, 500, 72, o);
  s.model.types[0].body_force = {g, 0, 0};
  std::size_t fluid = 0;
  for (auto t : s.particles.type) fluid += t == 0;
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, o.sim);
  const auto t0 = Clock::now();
  progress(o, "no-penetration: " + std::to_string(s.particles.size()) + " particles (" +
                  std::to_string(fluid) + " fluid) around " + std::to_string(ngrains) +
                  " grains of radius " + fmt(radius, 2) + ", g = " + fmt(g, 3) + ", " +
                  std::to_string(steps) + " steps (" + sim->pass_name() + ", " +
                  sim->backend_name() + ")");
  // A particle wall has no sharp surface: its wall particles sit at random depths below the cut,
  // so phi (and with it the model's surface phi = phi_c) fluctuates on the scale of the particle
  // spacing, n_w^(-1/3) = 0.52 rc here, and is lower on convex grains. Measured (H200, full
  // size): fluid reaches 0.25 rc below the cut, within the first layer of wall particles, and
  // no deeper. A fluid particle counts as having penetrated when it is deeper than one
  // wall-particle spacing (past the first layer); the report also gives how many sit within
  // that skin and the deepest one over the run.
  const double skin = std::cbrt(1.0 / kRho);
  struct Census {
    std::size_t beyond_skin = 0, within_skin = 0;
    double deepest = -1e300, mean_vx = 0;
  };
  auto census = [&](const sim::ParticleSet& p) {
    Census c;
    for (size_t i = 0; i < p.size(); ++i) {
      if (p.type[i] != 0) continue;
      const double d = depth(p.x[i], p.y[i], p.z[i]);
      c.deepest = std::max(c.deepest, d);
      if (d > skin)
        ++c.beyond_skin;
      else if (d > 0)
        ++c.within_skin;
      c.mean_vx += p.vx[i];
    }
    c.mean_vx /= static_cast<double>(fluid);
    return c;
  };
  Census last;
  std::size_t worst_beyond = 0;
  double deepest = -1e300;
  const std::uint64_t chunk = 1000;
  for (std::uint64_t done = 0; done < steps; done += chunk) {
    sim->run(chunk);
    last = census(sim->particles());
    worst_beyond = std::max(worst_beyond, last.beyond_skin);
    deepest = std::max(deepest, last.deepest);
    progress(o, "  step " + std::to_string(sim->step()) + ": " + std::to_string(last.beyond_skin) +
                    " fluid particles deeper than " + fmt(skin, 2) + " rc in the solid, " +
                    std::to_string(last.within_skin) + " within it, deepest " +
                    fmt(last.deepest, 3) + " rc, mean flow velocity " + fmt(last.mean_vx, 3) +
                    ", corrections " + std::to_string(sim->wall_corrections()) + " (" +
                    fmt(seconds_since(t0), 3) + " s)");
  }
  // The same system without the wall model: the soft fluid must get through the wall, or the
  // case could not tell a working corrector from a broken one.
  sim::Model bare = s.model;
  bare.wall_model.enabled = false;
  // The control at the small size runs longer than it used to (3000 steps): on the GPU a 3000-step
  // control reached only 0.37 rc (2026-12-02), short of the skin, although the leak is there.
  const std::uint64_t bare_steps = full ? 4000 : 6000;
  auto reference = sim::make_simulation(bare, s.box, s.particles, 0.01, o.sim);
  // The deepest over checks every 100 steps: a leak is a passing event (a particle that got in
  // may come out again), and one look at the end can miss it (seen on the GPU at small size:
  // 0.24 rc at step 3000 after deeper excursions).
  Census without;
  for (std::uint64_t done = 0; done < bare_steps; done += 100) {
    reference->run(100);
    const Census c = census(reference->particles());
    without.deepest = std::max(without.deepest, c.deepest);
    without.beyond_skin = std::max(without.beyond_skin, c.beyond_skin);
  }
  progress(o, "  without the wall model, over " + std::to_string(bare_steps) + " steps: up to " +
                  std::to_string(without.beyond_skin) + " fluid particles deeper than " +
                  fmt(skin, 2) + " rc, deepest " + fmt(without.deepest, 3) + " rc");
  r.quantities.push_back(
      judged("fluid particles deeper than " + fmt(skin, 2) +
                 " rc in the solid (worst of 10 checks over 10,000 steps)",
             static_cast<double>(worst_beyond), 0, 0, 0,
             "issue: zero (Li et al. 2018 predictor-corrector); skin = one wall-particle spacing",
             Comparison::AtMost));
  r.quantities.push_back(judged("deepest fluid particle without the wall model over " +
                                    std::to_string(bare_steps) + " steps (rc, checks every 100)",
                                without.deepest, 0, skin, 0,
                                "must get past the skin: shows the case can fail",
                                Comparison::AtLeast));
  r.quantities.push_back(judged("mean flow velocity along the force", last.mean_vx, 0, 0.01, 0,
                                "the fluid flows (the case is not trivially passed by a jam)",
                                Comparison::AtLeast));
  r.notes.push_back("deepest fluid particle over the run: " + fmt(deepest, 3) +
                    " rc below the grain surface (negative: outside); at the end " +
                    std::to_string(last.within_skin) + " fluid particles within the " +
                    fmt(skin, 2) + " rc skin; " + std::to_string(sim->wall_corrections()) +
                    " wall-model corrections in " + std::to_string(steps) +
                    " steps; without the model the deepest reached " + fmt(without.deepest, 3) +
                    " rc");
  return r;
}

}  // namespace mesorock::pipeline
