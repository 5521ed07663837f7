#pragma once
// Built-in physics validation cases (`rockflow validate`). Each measured quantity states its
// reference value, where that comes from, and the tolerance; a case passes when every quantity
// does.
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "pipeline/flow/systems.h"
#include "sim/model.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

enum class Comparison { Within, AtLeast, AtMost };

struct Quantity {
  std::string name;
  double measured = 0;
  double error = 0;  // one standard error (block averages), 0 where not statistical
  double reference = 0;
  double tolerance = 0;  // Within: |measured - reference| <= tolerance
  Comparison comparison = Comparison::Within;
  std::string source;  // where the reference comes from
  bool pass = false;

  void judge() {
    switch (comparison) {
      case Comparison::Within:
        pass = std::abs(measured - reference) <= tolerance;
        break;
      case Comparison::AtLeast:
        pass = measured >= reference;
        break;
      case Comparison::AtMost:
        pass = measured <= reference;
        break;
    }
  }
};

// A judged quantity: `source` says where the reference value comes from.
inline Quantity judged(std::string name, double measured, double error, double reference,
                       double tolerance, std::string source,
                       Comparison comparison = Comparison::Within) {
  Quantity q;
  q.name = std::move(name);
  q.measured = measured;
  q.error = error;
  q.reference = reference;
  q.tolerance = tolerance;
  q.comparison = comparison;
  q.source = std::move(source);
  q.judge();
  return q;
}

struct CaseResult {
  std::string name;
  std::vector<Quantity> quantities;
  std::vector<std::string> notes;  // e.g. "rho = 4: phase-separated; no EOS point reported"
  double seconds = 0;
  bool pass() const {
    if (quantities.empty()) return false;
    for (const auto& q : quantities)
      if (!q.pass) return false;
    return true;
  }
};

enum class CaseSize { Small, Full };

struct ValidateOptions {
  CaseSize size = CaseSize::Small;
  sim::DensityKernelKind density_kernel = sim::DensityKernelKind::Warren;
  sim::SimulationOptions sim;
  bool verbose = true;  // progress lines on stderr
};

// Small helpers the case files share: a progress line on stderr when verbose, a number with
// `precision` significant digits, and the seconds since t0.
inline void progress(const ValidateOptions& o, const std::string& what) {
  if (o.verbose) std::cerr << what << std::endl;
}
inline std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct ValidationCase {
  std::string name;
  std::string summary;
  std::function<CaseResult(const ValidateOptions&)> run;
};

const std::vector<ValidationCase>& validation_cases();
// The observables cases (validation_interfaces.cpp).
CaseResult run_slab_case(const ValidateOptions& o);
CaseResult run_viscosity_case(const ValidateOptions& o);
// The wall issue's cases (validation_walls.cpp).
CaseResult run_poiseuille_walls_case(const ValidateOptions& o);
CaseResult run_no_penetration_case(const ValidateOptions& o);
// The two-fluid cases (validation_two_fluid.cpp).
CaseResult run_interfacial_tension_case(const ValidateOptions& o);
CaseResult run_contact_angle_case(const ValidateOptions& o);
// The flooding case (validation_flooding.cpp).
CaseResult run_flooding_mini_case(const ValidateOptions& o);
const ValidationCase* find_validation_case(const std::string& name);

// The liquid of the wall cases: A = -40, B = 25, rd = 0.75, gamma = 4.5, rho = 7 (the viscosity
// case's), and its shear viscosity from the `viscosity` case at full size (H100, 2026-11-23,
// docs/validation.md): pooled over three forcings, 6.97 +- 0.057.
constexpr double kA = -40, kB = 25, kRd = 0.75, kGamma = 4.5, kRho = 7.0;
constexpr double kBulkViscosity = 6.97, kBulkViscosityError = 0.057;

// Depth below the pore surface (> 0 inside the solid, <= 0 in the pore) of a point.
using SolidDepth = std::function<double(double x, double y, double z)>;

// Walls of frozen liquid (validation_walls.cpp): equilibrates the liquid in a periodic box, then
// keeps particles in the pore (depth <= 0) as fluid and those with 0 < depth <= thickness as
// frozen wall; deeper ones are dropped. This is the packing of Liu et al. that the 2020 paper
// describes, affordable because validation boxes are small; the wall has the liquid's own
// structure and density, which the wall model's no-slip derivation assumes. Types: 0 fluid,
// 1 wall; every pair has the liquid's parameters; the wall model is on with n_w = rho.
BuiltSystem liquid_with_walls(const double L[3], const std::array<bool, 3>& periodic,
                              const SolidDepth& depth, double thickness, std::uint64_t equilibrate,
                              std::uint64_t seed, const ValidateOptions& o);

// Text table and the JSON object of the --json flag.
std::string format_case_text(const CaseResult& r);
std::string format_case_json(const CaseResult& r);

}  // namespace mesorock::pipeline
