#pragma once
// The viscosity calibration of `rockflow sweep`: the shear viscosity of a one-type fluid by
// reverse Poiseuille flow (reverse_poiseuille.h), cached in a file keyed by the fluid's parameters
// and reused.
#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "sim/simulation.h"

namespace mesorock::pipeline {

class ProgressMeter;

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
