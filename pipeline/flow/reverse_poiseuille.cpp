#include "pipeline/flow/reverse_poiseuille.h"

#include <algorithm>
#include <cmath>

#include "pipeline/flow/statistics.h"
#include "sim/observables.h"

namespace mesorock::pipeline {

void drive_reverse_poiseuille(sim::Model& model, double g) {
  model.types[0].body_force = {g, 0, 0};
  model.body_force_profile = sim::BodyForceProfile::Reversed;
  model.body_force_axis = 2;
}

double reverse_poiseuille_eta(const std::vector<double>& u, const std::vector<double>& err,
                              double width, double rho, double g, double* worst_chi2) {
  const int bins = static_cast<int>(u.size());
  double inv_var = 0, weighted = 0;
  for (int half = 0; half < 2; ++half) {
    std::vector<double> z, uu, ee;
    for (int b = half * bins / 2; b < (half + 1) * bins / 2; ++b) {
      z.push_back((b + 0.5) * width);
      uu.push_back(u[static_cast<size_t>(b)]);
      ee.push_back(std::max(err[static_cast<size_t>(b)], 1e-12));
    }
    double zc = 0;
    for (double v : z) zc += v;
    const ParabolaFit f = fit_parabola(z, uu, ee, zc / static_cast<double>(z.size()));
    const double sign = half == 0 ? 1.0 : -1.0;
    const double eta = -sign * rho * g / (2 * f.c2);
    const double e = std::abs(eta) * f.c2_error / std::abs(f.c2);
    inv_var += 1 / (e * e);
    weighted += eta / (e * e);
    if (worst_chi2) *worst_chi2 = std::max(*worst_chi2, f.chi2_per_dof);
  }
  return weighted / inv_var;
}

namespace {

// The mean velocity along x per bin of one block's summed bin sums (0 where no particle came).
std::vector<double> block_velocity(const std::vector<double>& block, int bins) {
  std::vector<double> u(static_cast<size_t>(bins));
  for (int b = 0; b < bins; ++b) {
    const double n = block[static_cast<size_t>(b) * sim::kBinFields + sim::kBinCount];
    u[static_cast<size_t>(b)] =
        n > 0 ? block[static_cast<size_t>(b) * sim::kBinFields + sim::kBinVx] / n : 0.0;
  }
  return u;
}

}  // namespace

ReversePoiseuille sample_reverse_poiseuille(sim::Simulation& sim, const sim::BoxSpec& box,
                                            const ReversePoiseuilleSampling& sampling, double rho,
                                            double g, const ProfileSampleCheck& check) {
  const int bins = sampling.bins;
  const sim::BinGrid grid = sim::BinGrid::profile(2, bins, box.lo, box.hi);
  sim::BinnedAverage profile(grid);
  const std::uint64_t per_block = sampling.samples_per_block;
  std::vector<std::vector<double>> block_sums(static_cast<size_t>(sampling.blocks));
  for (std::uint64_t k = 0; k < per_block * sampling.blocks; ++k) {
    sim.run(sampling.every);
    const auto sums = sim.bin_sums(grid);
    if (check) check(sums);
    profile.add(sums);
    auto& blk = block_sums[static_cast<size_t>(k / per_block)];
    if (blk.empty()) blk.assign(sums.size(), 0.0);
    for (size_t q = 0; q < sums.size(); ++q) blk[q] += sums[q];
  }
  const double width = box.length(2) / bins;
  auto eta_of = [&](const std::vector<double>& u, const std::vector<double>& err,
                    double* worst_chi2) {
    return reverse_poiseuille_eta(u, err, width, rho, g, worst_chi2);
  };
  const auto u = profile.velocity(0);
  const auto T = profile.temperature();
  ReversePoiseuille r;
  double tsum = 0;
  for (double v : T.mean) tsum += v;
  r.temperature = tsum / static_cast<double>(T.mean.size());
  for (double v : u.mean) r.u_max = std::max(r.u_max, std::abs(v));
  const std::vector<double> ones(static_cast<size_t>(bins), 1.0);
  const bool have_errors = profile.blocks() >= 2;
  r.eta = eta_of(u.mean, have_errors ? u.error : ones, have_errors ? &r.chi2_per_dof : nullptr);
  if (!have_errors) r.chi2_per_dof = NAN;
  // The error from the blocks' fluidity 1 / eta, which is linear in the profile's curvature: the
  // block values of eta = -rho g / (2 c2) itself have heavy tails at weak forcing, and their
  // standard error came out 2-3 times below the spread of eta over seeds (docs/validation.md,
  // "How firm the small cases are"). Neighbouring blocks are correlated (a block is shorter than
  // the flow's viscous time), so the error is the largest standard error over the blocks
  // merged 1, 2 and 4 at a time (Flyvbjerg & Petersen 1989), propagated to eta.
  std::vector<double> fluidity;
  for (const auto& blk : block_sums)
    fluidity.push_back(1 / eta_of(block_velocity(blk, bins), ones, nullptr));
  double error = 0;
  for (size_t merged : {size_t{0}, fluidity.size() / 2, fluidity.size() / 4})
    error = std::max(error, block_average(fluidity, merged).error);
  r.eta_error = r.eta * r.eta * error;
  return r;
}

ReversePoiseuille measure_reverse_poiseuille(BuiltSystem s, double g, double rho,
                                             std::uint64_t equilibrate, std::uint64_t sample,
                                             int blocks, const sim::SimulationOptions& options) {
  drive_reverse_poiseuille(s.model, g);
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, options);
  sim->run(equilibrate);
  ReversePoiseuilleSampling sampling;
  sampling.bins = static_cast<int>(s.box.length(2) * 2);  // 0.5 rc bins (truncated)
  sampling.every = 10;
  sampling.blocks = static_cast<std::uint64_t>(blocks);
  sampling.samples_per_block = sample / sampling.every / sampling.blocks;
  return sample_reverse_poiseuille(*sim, s.box, sampling, rho, g);
}

}  // namespace mesorock::pipeline
