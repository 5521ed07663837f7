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

#include "mesorock/number_text.h"
#include "pipeline/flow/progress.h"
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
  // Added to every seed of a case's particles and thermostat (`--seed-offset`; 0: the seeds of
  // the recorded results). Another offset is another sample of the same physics: how often a
  // case passes over many offsets measures how firm its verdict is (docs/validation.md).
  std::uint64_t seed_offset = 0;
};

// Small helpers the case files share: a progress line on stderr when verbose, a number with
// `precision` significant digits (mesorock::fmt, mesorock/number_text.h), and the seconds since t0.
inline void progress(const ValidateOptions& o, const std::string& what) {
  if (!o.verbose) return;
  clear_progress_line(std::cerr);  // a redrawn progress meter line (pipeline/flow/progress.h)
  std::cerr << what << std::endl;
}
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct ValidationCase {
  std::string name;
  std::string summary;
  std::function<CaseResult(const ValidateOptions&)> run;
  // Work in million particle-steps at the small and full sizes, for the progress meter's ETA
  // (0 = not known: the meter shows elapsed time and MPS/s only).
  double work_small = 0, work_full = 0;
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
CaseResult run_wn_contact_angle_case(const ValidateOptions& o);  // validation_capillary.cpp
// The flooding case (validation_flooding.cpp).
CaseResult run_flooding_mini_case(const ValidateOptions& o);
// The permeability cases (validation_permeability.cpp).
CaseResult run_perm_slit_case(const ValidateOptions& o);
CaseResult run_perm_tube_case(const ValidateOptions& o);
CaseResult run_perm_sphere_array_case(const ValidateOptions& o);
CaseResult run_darcy_linearity_case(const ValidateOptions& o);
// The two-phase flow case (validation_relperm.cpp) and the capillary pressure case
// (validation_capillary.cpp).
CaseResult run_relperm_slit_case(const ValidateOptions& o);
CaseResult run_laplace_cylinder_case(const ValidateOptions& o);
CaseResult run_capillary_slit_case(const ValidateOptions& o);
// Capillary entry under stepped pressure, rockflow pc's machinery (validation_drainage.cpp).
CaseResult run_drainage_slit_case(const ValidateOptions& o);
// Sum of the interface tensions of a film that is flat in y-z, from one stress sample:
// Lx (s_xx - (s_yy + s_zz) / 2) = integral over x of (p_N - p_T). The kinetic and conservative
// parts carry the tension; the dissipative and random virials average to zero at equilibrium
// (no flow) and only add noise, so they are left out (the same definition as Groot & Warren's
// pressure, which the eos cases use). validation_two_fluid.cpp.
double tension_sum(const sim::StressSample& st, double Lx);
// Circular mean along axis 0 of a count field (bins x fastest; count of bin b of row r at
// counts[(r nx + b) stride]), as a bin offset from the grid's lower edge in bins, in [0, nx).
// validation_two_fluid.cpp.
double circular_centre_bins(const std::vector<double>& counts, int nx, int nrest, int stride);
const ValidationCase* find_validation_case(const std::string& name);

// Text table and the JSON object of the --json flag.
std::string format_case_text(const CaseResult& r);
std::string format_case_json(const CaseResult& r);

}  // namespace mesorock::pipeline
