#pragma once
// Thermostat: dissipative + random pair forces (Espanol & Warren 1995 fluctuation-dissipation).
// F^D = -gamma w_R^2 (e . v_ij) e,  F^R = sigma w_R xi_ij e / sqrt(dt),  w_R = 1 - r.
// Scene: model.thermostat = true, [[pairs]] key gamma.
#include <array>
#include <cmath>

#include "sim/hd.h"
#include "sim/model.h"
#include "sim/terms/pair_params.h"

namespace mesorock::sim {

struct NoThermostat {
  static constexpr bool enabled = false;
  static constexpr const char* name = "off";

  static constexpr std::array<const char*, 0> pair_keys{};
  static constexpr const char* chosen_when = "when model.thermostat = false";
  static bool matches(const Model& m) { return !m.thermostat; }
  static void read_pair(PairEntry& /*e*/, PairSpec& /*p*/) {}
  static void check_pair(const PairSpec& /*p*/) {}
  template <class Real>
  static void fill_pair(const PairSpec& /*p*/, const Model& /*m*/, PairParams<Real>& /*row*/) {}
};

struct DPDThermostat {
  static constexpr bool enabled = true;
  static constexpr const char* name = "dpd";
  template <class Real>
  MESO_HD static MESO_INLINE Real dissipative(Real r, Real e_dot_v, const PairParams<Real>& p) {
    const Real w = Real(1) - r;
    return -p.gamma * w * w * e_dot_v;
  }
  template <class Real>
  MESO_HD static MESO_INLINE Real random(Real r, Real xi, Real inv_sqrt_dt,
                                         const PairParams<Real>& p) {
    return p.sigma * (Real(1) - r) * xi * inv_sqrt_dt;
  }

  // The parameters (host side; sim/terms.h calls these for the selected term).
  static constexpr std::array<const char*, 1> pair_keys{"gamma"};
  static constexpr const char* chosen_when = "when model.thermostat = true";
  static bool matches(const Model& m) { return m.thermostat; }
  static void read_pair(PairEntry& e, PairSpec& p) {
    p.gamma = e.require_number("gamma");
    if (p.gamma < 0) e.reject("gamma", "must be >= 0", p.gamma);
  }
  static void check_pair(const PairSpec& /*p*/) {}  // gamma >= 0 is checked for every pair
  // sigma^2 = 2 gamma kBT: the fluctuation-dissipation theorem.
  template <class Real>
  static void fill_pair(const PairSpec& p, const Model& m, PairParams<Real>& row) {
    row.gamma = static_cast<Real>(p.gamma);
    row.sigma = static_cast<Real>(std::sqrt(2.0 * p.gamma * m.kBT));
  }
};

}  // namespace mesorock::sim
