#pragma once
// Shear viscosity of a one-type fluid by reverse Poiseuille flow (Backer et al. 2005), shared by
// the `viscosity` validation case and the viscosity calibration of `rockflow sweep`, which caches
// its result in a file keyed by the fluid's parameters and reuses it.
#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "pipeline/flow/systems.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

class ProgressMeter;

struct ReversePoiseuille {
  double eta = 0, eta_error = 0;
  double chi2_per_dof = 0;  // worse of the two halves' parabola fits
  double temperature = 0;   // mean bin temperature
  double u_max = 0;         // largest |mean velocity| of a bin
};

// A body force +g x for z below the box's mid-plane and -g x above drives two opposite parabolic
// flows in the periodic box of `s` (one type, type 0). In each half the steady Stokes equation
// eta u'' = -rho g s gives u = c0 + c1 z + c2 z^2, eta = -s rho g / (2 c2). After `equilibrate`
// steps the velocity profile is sampled every 10 steps in 0.5 rc bins for `sample` steps; eta
// comes from the whole run's profile (the halves' fits weighted by their errors), its error from
// the scatter of eta over `blocks` consecutive blocks, each fitted on its own (the bins of one
// profile are correlated, so a fit that treats them as independent underestimates the error).
// eta from one reverse-Poiseuille velocity profile u (bins of `width` along the box, +g below the
// mid-plane, -g above): each half's parabola fit, the two averaged with weights 1/err^2. The worst
// half's chi^2 per dof goes to *worst_chi2 when given.
double reverse_poiseuille_eta(const std::vector<double>& u, const std::vector<double>& err,
                              double width, double rho, double g, double* worst_chi2);

ReversePoiseuille measure_reverse_poiseuille(BuiltSystem s, double g, double rho,
                                             std::uint64_t equilibrate, std::uint64_t sample,
                                             int blocks, const sim::SimulationOptions& options);

// The fluid a calibration runs: one type with these pair parameters at this number density.
struct FluidSpec {
  sim::ConservativeKind conservative = sim::ConservativeKind::MDPD;
  sim::DensityKernelKind density_kernel = sim::DensityKernelKind::Warren;
  double A = -40, B = 25, gamma = 4.5, rd = 0.75, kBT = 1, lambda = 0.5;
  double density = 7;
  double dt = 0.01;
  sim::Precision precision = sim::Precision::Double;
};

// tiny: 4 x 4 x 8 box, 300 + 2,000 steps (tests; error bars of several %); small: 6 x 6 x 12,
// 1,500 + 8,000 (the `viscosity` case's small size); full: 10 x 10 x 24, 4,000 + 40,000 (its
// full size, about 1%). Peak shear rate about 0.1 for eta about 7.
enum class CalibrationSize { Tiny, Small, Full };
const char* to_string(CalibrationSize s);
CalibrationSize parse_calibration_size(const std::string& s);  // ConfigError if unknown

struct CalibratedViscosity {
  double value = 0, error = 0;
  std::string source;  // "cache" or "calibration"
  std::filesystem::path cache_file;
  nlohmann::json record;  // what the cache file holds: key, result, provenance
};

// The cache key: every parameter that changes the result, as canonical JSON text.
std::string calibration_key(const FluidSpec& fluid, CalibrationSize size);
// $MESOROCK_CACHE_DIR, else $XDG_CACHE_HOME/mesorock, else $HOME/.cache/mesorock; + /viscosity.
std::filesystem::path default_viscosity_cache();
// The viscosity of `fluid` from cache_dir (a file named by a hash of the key, holding the key,
// which must match), else by a calibration run whose result is then stored there (atomically).
CalibratedViscosity calibrated_viscosity(const FluidSpec& fluid, CalibrationSize size,
                                         const std::filesystem::path& cache_dir,
                                         const sim::SimulationOptions& options,
                                         ProgressMeter* meter = nullptr);

}  // namespace mesorock::pipeline
