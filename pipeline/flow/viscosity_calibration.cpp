#include "pipeline/flow/viscosity_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "mesorock/atomic_file.h"
#include "mesorock/cache.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/flow/progress.h"
#include "pipeline/flow/statistics.h"
#include "sim/observables.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

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

ReversePoiseuille measure_reverse_poiseuille(BuiltSystem s, double g, double rho,
                                             std::uint64_t equilibrate, std::uint64_t sample,
                                             int blocks, const sim::SimulationOptions& options) {
  const double Lz = s.box.length(2);
  s.model.types[0].body_force = {g, 0, 0};
  s.model.body_force_profile = sim::BodyForceProfile::Reversed;
  s.model.body_force_axis = 2;
  auto sim = sim::make_simulation(s.model, s.box, s.particles, 0.01, options);
  sim->run(equilibrate);
  const int bins = static_cast<int>(Lz * 2);  // 0.5 rc bins
  const sim::BinGrid grid = sim::BinGrid::profile(2, bins, s.box.lo, s.box.hi);
  sim::BinnedAverage profile(grid);
  const std::uint64_t every = 10;
  const std::uint64_t samples = sample / every, per_block = samples / blocks;
  std::vector<std::vector<double>> block_sums(static_cast<size_t>(blocks));
  for (std::uint64_t k = 0; k < per_block * blocks; ++k) {
    sim->run(every);
    const auto sums = sim->bin_sums(grid);
    profile.add(sums);
    auto& blk = block_sums[static_cast<size_t>(k / per_block)];
    if (blk.empty()) blk.assign(sums.size(), 0.0);
    for (size_t q = 0; q < sums.size(); ++q) blk[q] += sums[q];
  }
  const double width = Lz / bins;
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
  r.eta = eta_of(u.mean, u.error, &r.chi2_per_dof);
  std::vector<double> etas;
  for (const auto& blk : block_sums) {
    std::vector<double> ub(static_cast<size_t>(bins)), ones(static_cast<size_t>(bins), 1.0);
    for (int b = 0; b < bins; ++b) {
      const double n = blk[static_cast<size_t>(b) * sim::kBinFields + sim::kBinCount];
      ub[static_cast<size_t>(b)] =
          n > 0 ? blk[static_cast<size_t>(b) * sim::kBinFields + sim::kBinVx] / n : 0.0;
    }
    etas.push_back(eta_of(ub, ones, nullptr));
  }
  r.eta_error = block_average(etas, 0).error;  // plain standard error of the block values
  return r;
}

const char* to_string(CalibrationSize s) {
  switch (s) {
    case CalibrationSize::Tiny:
      return "tiny";
    case CalibrationSize::Small:
      return "small";
    case CalibrationSize::Full:
      return "full";
  }
  return "small";
}

CalibrationSize parse_calibration_size(const std::string& s) {
  if (s == "tiny") return CalibrationSize::Tiny;
  if (s == "small") return CalibrationSize::Small;
  if (s == "full") return CalibrationSize::Full;
  throw ConfigError("calibration size must be tiny, small or full (got " + s + ")");
}

namespace {

struct Plan {
  double lxy, lz;
  std::uint64_t equilibrate, sample;
  int blocks;
};

Plan plan_of(CalibrationSize size) {
  switch (size) {
    case CalibrationSize::Tiny:
      return {4, 8, 300, 2000, 10};
    case CalibrationSize::Small:
      return {6, 12, 1500, 8000, 20};
    case CalibrationSize::Full:
      return {10, 24, 4000, 40000, 20};
  }
  return {6, 12, 1500, 8000, 20};
}

constexpr std::uint64_t kCalibrationSeed = 97;
constexpr double kPeakShearRate = 0.1, kViscosityGuess = 7.0;

}  // namespace

std::string calibration_key(const FluidSpec& f, CalibrationSize size) {
  const Plan p = plan_of(size);
  nlohmann::json j = {{"method", "reverse-poiseuille-1"},
                      {"conservative", sim::to_string(f.conservative)},
                      {"A", f.A},
                      {"gamma", f.gamma},
                      {"kBT", f.kBT},
                      {"lambda", f.lambda},
                      {"density", f.density},
                      {"dt", f.dt},
                      {"precision", sim::to_string(f.precision)},
                      {"size", to_string(size)},
                      {"box", {p.lxy, p.lxy, p.lz}},
                      {"steps", {p.equilibrate, p.sample}},
                      {"seed", kCalibrationSeed}};
  if (f.conservative == sim::ConservativeKind::MDPD) {
    j["B"] = f.B;
    j["rd"] = f.rd;
    j["density_kernel"] = sim::to_string(f.density_kernel);
  }
  return j.dump();  // nlohmann::json orders keys: the text is canonical
}

fs::path default_viscosity_cache() {
  return default_cache_dir("viscosity");
}

CalibratedViscosity calibrated_viscosity(const FluidSpec& fluid, CalibrationSize size,
                                         const fs::path& cache_dir,
                                         const sim::SimulationOptions& options,
                                         ProgressMeter* meter) {
  const std::string key = calibration_key(fluid, size);
  char name[40];
  std::snprintf(name, sizeof name, "eta-%016llx.json", static_cast<unsigned long long>(fnv1a(key)));
  CalibratedViscosity r;
  r.cache_file = cache_dir / name;
  if (fs::exists(r.cache_file)) {
    std::ifstream in(r.cache_file);
    nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (j.is_object() && j.contains("key") && j["key"].dump() == key && j.contains("viscosity")) {
      r.value = j["viscosity"].at("value").get<double>();
      r.error = j["viscosity"].at("error").get<double>();
      r.source = "cache";
      r.record = j;
      return r;
    }
    // Another key with the same hash, or a damaged file: calibrate again and replace it.
  }
  if (!(fluid.density > 0)) throw ConfigError("viscosity calibration: density must be positive");
  const Plan p = plan_of(size);
  const double L[3] = {p.lxy, p.lxy, p.lz};
  BuiltSystem s = fluid.conservative == sim::ConservativeKind::MDPD
                      ? make_bulk_mdpd(fluid.A, fluid.B, fluid.rd, fluid.gamma, fluid.density, L,
                                       kCalibrationSeed, fluid.density_kernel)
                      : make_bulk_dpd(fluid.A, fluid.gamma, fluid.density, L, kCalibrationSeed);
  s.model.kBT = fluid.kBT;
  s.model.lambda = fluid.lambda;
  s.model.precision = fluid.precision;
  // Peak shear rate rho g Lz / (4 eta) of about 0.1 for eta about 7 (the papers' liquids).
  const double g = kPeakShearRate * 4 * kViscosityGuess / (fluid.density * p.lz);
  if (meter) {
    meter->add_total(static_cast<double>(s.particles.size()) *
                     static_cast<double>(p.equilibrate + p.sample));
    meter->set_phase(std::string("viscosity calibration (") + to_string(size) + ", " +
                     std::to_string(s.particles.size()) + " particles)");
  }
  const ReversePoiseuille m =
      measure_reverse_poiseuille(s, g, fluid.density, p.equilibrate, p.sample, p.blocks, options);
  if (!std::isfinite(m.eta) || !(m.eta > 0))
    throw NumericalError("viscosity calibration gave eta = " + std::to_string(m.eta) +
                         " (is the fluid a homogeneous liquid at this density?)");
  r.value = m.eta;
  r.error = m.eta_error;
  r.source = "calibration";
  r.record = {{"key", nlohmann::json::parse(key)},
              {"viscosity", {{"value", m.eta}, {"error", m.eta_error}}},
              {"unit", "sqrt(m kBT) / rc^2 (reduced)"},
              {"method",
               "reverse Poiseuille flow (Backer et al. 2005): parabola fits of each half's "
               "velocity profile; error from the scatter over blocks"},
              {"body_force", g},
              {"peak_shear_rate", fluid.density * g * p.lz / (4 * m.eta)},
              {"parabola_chi2_per_dof", m.chi2_per_dof},
              {"temperature", m.temperature},
              {"mesorock_version", kVersion},
              {"git_commit", kGitCommit}};
  std::error_code ec;
  fs::create_directories(cache_dir, ec);
  if (ec)
    throw IoError(cache_dir.string() + ": cannot create the viscosity cache: " + ec.message());
  write_text_atomically(r.cache_file, r.record.dump(2) + "\n");
  return r;
}

}  // namespace mesorock::pipeline
