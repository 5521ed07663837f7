#pragma once
// Many-body DPD (Warren 2003; the papers' eq. 1) and its density kernels.
// Scene: model.conservative = "mdpd" with model.density_kernel, [[pairs]] keys A and B.
#include <array>

#include "sim/hd.h"
#include "sim/model.h"
#include "sim/terms/pair_params.h"

namespace mesorock::sim {

// Density kernels: rho_i = sum_{j != i} w(r_ij), normalised so that int_0^rd 4 pi r^2 w dr = 1.

// The papers' kernel (Warren 2003; Xia et al. 2017, 2020): w(r) = 15 / (2 pi rd^3) (1 - r/rd)^2.
struct DensityKernelWarren {
  static constexpr const char* name = "warren";
  static constexpr DensityKernelKind kind = DensityKernelKind::Warren;
  template <class Real>
  MESO_HD static MESO_INLINE Real weight(Real r, Real rd) {
    if (r >= rd) return Real(0);
    const Real s = Real(1) - r / rd;
    return Real(15.0 / (2.0 * 3.14159265358979323846)) / (rd * rd * rd) * s * s;
  }
};

// Lucy kernel as in LAMMPS DPD-MESO (pair_style mdpd/rhosum), h = rd:
// w(r) = 105 / (16 pi h^3) (1 + 3 r/h) (1 - r/h)^3.
struct DensityKernelLucy {
  static constexpr const char* name = "lucy";
  static constexpr DensityKernelKind kind = DensityKernelKind::Lucy;
  template <class Real>
  MESO_HD static MESO_INLINE Real weight(Real r, Real rd) {
    if (r >= rd) return Real(0);
    const Real q = r / rd;
    const Real s = Real(1) - q;
    return Real(105.0 / (16.0 * 3.14159265358979323846)) / (rd * rd * rd) * (Real(1) + 3 * q) * s *
           s * s;
  }
};

// F^C = A (1 - r) e + B (rho_i + rho_j) (1 - r/rd) e, the second part only for r < rd.
// The density kernel is a template parameter: it selects the density pass, not this formula.
template <class DensityKernel>
struct ConservativeMDPD {
  static constexpr bool enabled = true;
  static constexpr bool needs_density = true;
  static constexpr const char* name = "mdpd";
  using density_kernel = DensityKernel;
  template <class Real>
  MESO_HD static MESO_INLINE Real magnitude(Real r, Real rho_i, Real rho_j,
                                            const PairParams<Real>& p, Real rd) {
    const Real attraction = p.A * (Real(1) - r);
    const Real repulsion = r < rd ? p.B * (rho_i + rho_j) * (Real(1) - r / rd) : Real(0);
    return attraction + repulsion;
  }

  // The parameters (host side; sim/terms.h calls these for the selected term).
  static constexpr std::array<const char*, 2> pair_keys{"A", "B"};
  static constexpr const char* chosen_when = "when model.conservative = \"mdpd\" (give A and B)";
  static bool matches(const Model& m) {
    return m.conservative == ConservativeKind::MDPD && m.density_kernel == DensityKernel::kind;
  }
  static void read_pair(PairEntry& e, PairSpec& p) {
    p.A = e.require_number("A");
    p.B = e.require_number("B");
    if (p.B < 0) e.reject("B", "must be >= 0", p.B);
  }
  static void check_pair(const PairSpec& /*p*/) {}
  template <class Real>
  static void fill_pair(const PairSpec& p, const Model& /*m*/, PairParams<Real>& row) {
    row.A = static_cast<Real>(p.A);
    row.B = static_cast<Real>(p.B);
  }
};

}  // namespace mesorock::sim
