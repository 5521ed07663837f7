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
#include "pipeline/flow/reverse_poiseuille.h"
#include "pipeline/flow/systems.h"

namespace mesorock::pipeline {

namespace fs = std::filesystem;

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
  std::error_code ec;
  // A folder at the entry's name read as "basic_filebuf::underflow" (an internal error).
  if (fs::exists(r.cache_file, ec) && !fs::is_regular_file(r.cache_file, ec))
    throw IoError(r.cache_file.string() +
                  ": not a regular file where the viscosity cache keeps a calibration: remove it, "
                  "or give --viscosity-cache another folder");
  if (fs::exists(r.cache_file)) {
    std::ifstream in(r.cache_file);
    nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    // A usable entry: this key, a positive viscosity and an error of at least zero (NaN for a
    // missing or non-numeric field fails both comparisons).
    const auto number = [&](const char* name) {
      const nlohmann::json v = j["viscosity"].value(name, nlohmann::json());
      return v.is_number() ? v.get<double>() : std::nan("");
    };
    const bool ours = j.is_object() && j.contains("key") && j["key"].dump() == key &&
                      j.contains("viscosity") && j["viscosity"].is_object();
    const double value = ours ? number("value") : std::nan(""),
                 error = ours ? number("error") : std::nan("");
    if (value > 0 && std::isfinite(value) && error >= 0 && std::isfinite(error)) {
      r.value = value;
      r.error = error;
      r.source = "cache";
      r.record = j;
      return r;
    }
    // Another key with the same hash, or a damaged file: calibrate again and replace it.
  }
  if (!(fluid.density > 0)) throw ConfigError("viscosity calibration: density must be positive");
  // The cache must take the result, checked before the calibration's minutes: a cache that could
  // not be written failed the sweep after calibrating, and the calibration was lost.
  fs::create_directories(cache_dir, ec);
  if (ec)
    throw IoError(cache_dir.string() + ": cannot create the viscosity cache: " + ec.message());
  try {
    write_text_file(temporary_path_for(r.cache_file), "");
  } catch (const IoError&) {
    throw IoError(cache_dir.string() +
                  ": the viscosity cache cannot be written (--viscosity-cache)");
  }
  fs::remove(temporary_path_for(r.cache_file), ec);
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
  write_text_atomically(r.cache_file, r.record.dump(2) + "\n");
  return r;
}

}  // namespace mesorock::pipeline
