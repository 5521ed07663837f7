#pragma once
// Standard DPD (Groot & Warren 1997): F^C = a (1 - r) e, a = A > 0. No density pass.
// Potential U(r) = a/2 (1 - r)^2. Scene: model.conservative = "dpd", [[pairs]] key a.
#include <array>

#include "mesorock/errors.h"
#include "sim/hd.h"
#include "sim/model.h"
#include "sim/terms/pair_params.h"

namespace mesorock::sim {

struct ConservativeDPD {
  static constexpr bool enabled = true;
  static constexpr bool needs_density = false;
  static constexpr const char* name = "dpd";
  using density_kernel = void;
  template <class Real>
  MESO_HD static MESO_INLINE Real magnitude(Real r, Real /*rho_i*/, Real /*rho_j*/,
                                            const PairParams<Real>& p, Real /*rd*/) {
    return p.A * (Real(1) - r);
  }

  // The parameters (host side; sim/terms.h calls these for the selected term).
  static constexpr std::array<const char*, 1> pair_keys{"a"};
  static constexpr const char* chosen_when =
      "when model.conservative = \"dpd\" (give the repulsion a)";
  static bool matches(const Model& m) { return m.conservative == ConservativeKind::DPD; }
  // docs/physics.md writes a = -A; the solver stores A = a (see ARCHITECTURE.md).
  static void read_pair(PairEntry& e, PairSpec& p) {
    p.A = e.require_number("a");
    if (p.A < 0) e.reject("a", "must be >= 0 (a is the DPD repulsion amplitude)", p.A);
  }
  // The model's check (sim/validate_inputs.cpp), after the checks every pair gets.
  static void check_pair(const PairSpec& p) {
    if (p.B != 0) throw ConfigError("B is only meaningful for the mdpd conservative force");
  }
  template <class Real>
  static void fill_pair(const PairSpec& p, const Model& /*m*/, PairParams<Real>& row) {
    row.A = static_cast<Real>(p.A);
  }
};

}  // namespace mesorock::sim
