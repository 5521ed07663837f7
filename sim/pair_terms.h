#pragma once
// Force terms as small functors with plain parameter structs (hoomd-blue Evaluator style).
// Each is __host__ __device__ and composed at compile time by the pass templates in
// sim/kernels.h. A term a scene does not ask for is an "Off" type whose members are constexpr
// false or empty: the compiler removes it together with its loads and arrays.
//
// Reduced units: rc = m = kBT = 1. r = |r_ij|, e = r_ij / r, r_ij = r_i - r_j, v_ij = v_i - v_j.
// Every pair term is zero for r >= rc = 1.
#include "sim/hd.h"

namespace mesorock::sim {

// Per type-pair parameters, stored in a symmetric ntypes x ntypes table.
template <class Real>
struct PairParams {
  Real A = 0;      // conservative amplitude: A < 0 attracts (mDPD), a = A > 0 repels (DPD)
  Real B = 0;      // many-body repulsion amplitude (mDPD), B > 0
  Real gamma = 0;  // dissipation coefficient
  Real sigma = 0;  // random amplitude, sigma^2 = 2 gamma kBT (set by the table builder)
};

// ---------------------------------------------------------------------------------------------
// Density kernels: rho_i = sum_{j != i} w(r_ij), normalised so that int_0^rd 4 pi r^2 w dr = 1.

// The papers' kernel (Warren 2003; Xia et al. 2017, 2020): w(r) = 15 / (2 pi rd^3) (1 - r/rd)^2.
struct DensityKernelWarren {
  static constexpr const char* name = "warren";
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
  template <class Real>
  MESO_HD static MESO_INLINE Real weight(Real r, Real rd) {
    if (r >= rd) return Real(0);
    const Real q = r / rd;
    const Real s = Real(1) - q;
    return Real(105.0 / (16.0 * 3.14159265358979323846)) / (rd * rd * rd) * (Real(1) + 3 * q) * s *
           s * s;
  }
};

// ---------------------------------------------------------------------------------------------
// Conservative terms. magnitude() returns F^C . e (positive = repulsive).

// Standard DPD (Groot & Warren 1997): F^C = a (1 - r) e, a = A > 0. No density pass.
// Potential U(r) = a/2 (1 - r)^2.
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
};

// Many-body DPD (Warren 2003; the papers' eq. 1):
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
};

// ---------------------------------------------------------------------------------------------
// Thermostat: dissipative + random pair forces (Espanol & Warren 1995 fluctuation-dissipation).
// F^D = -gamma w_R^2 (e . v_ij) e,  F^R = sigma w_R xi_ij e / sqrt(dt),  w_R = 1 - r.

struct NoThermostat {
  static constexpr bool enabled = false;
  static constexpr const char* name = "off";
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
};

// ---------------------------------------------------------------------------------------------
// Body force per particle (m = 1), applied after the pair loop: F = s(x) g_type, where the sign
// s depends on the position only for the reverse-Poiseuille profile.

struct NoBodyForce {
  static constexpr bool enabled = false;
  static constexpr const char* name = "off";
};

// s = 1: a uniform pressure gradient (or gravity) per type.
struct PerTypeBodyForce {
  static constexpr bool enabled = true;
  static constexpr const char* name = "per-type";
  template <class Real>
  MESO_HD static MESO_INLINE Real sign(Real /*coordinate*/, Real /*midplane*/) {
    return Real(1);
  }
};

// Reverse Poiseuille flow (Backer, Lowe, Hoefsloot & Iedema, J. Chem. Phys. 122, 154503 (2005)):
// s = +1 below the box's mid-plane along the profile axis, -1 above it. A periodic box then holds
// two opposite parabolic flows with no walls, from which the shear viscosity follows.
struct ReversedBodyForce {
  static constexpr bool enabled = true;
  static constexpr const char* name = "reversed";
  template <class Real>
  MESO_HD static MESO_INLINE Real sign(Real coordinate, Real midplane) {
    return coordinate < midplane ? Real(1) : Real(-1);
  }
};

}  // namespace mesorock::sim
