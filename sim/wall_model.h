#pragma once
// The arbitrary-geometry wall model of Li, Bian, Tang & Karniadakis, "A dissipative particle
// dynamics method for arbitrarily complex geometries", J. Comput. Phys. 355 (2018) 534-547
// (arXiv 1612.08761), as used by the 2020 paper for pore walls made of frozen particles.
//
// Three parts, all local to a fluid particle i and its neighbours within rc = 1:
//
// 1. Boundary volume fraction (BVF), from the local particle configuration only:
//      phi_i = sum_{j in wall} W(r_ij) / sum_{j != i} W(r_ij),   W(r) = (1 - r)^2,
//    0 in the bulk fluid, about 1/2 on a flat wall surface (equal number densities), towards 1
//    inside the wall. Normalising by all neighbours makes phi independent of the local density.
//    The wall-side normal is n_i = sum_{j in wall} W(r_ij) e_ij / |...| (e_ij points from the
//    wall particle to i, out of the wall).
//
// 2. Penetration and the predictor-corrector: after the drift x(t+dt) = x(t) + dt v (the
//    predictor), a fluid particle with phi_i > phi_c that moves into the wall (v . n < 0) has its
//    drift redone with the normal velocity reflected (the corrector):
//      v' = v - 2 (v . n) n   (specular; bounce-back reverses all of v),
//      x(t+dt) = x(t) + dt v' = x_predicted + dt (v' - v).
//    phi_c = 1/2 puts the threshold on the wall surface.
//
// 3. No-slip through an effective fluid-wall dissipation. A particle at distance h from a flat
//    wall in a linear shear flow u = s z (no slip at z = 0) should feel from the wall region the
//    dissipative force that fluid continuing the profile below the wall (velocity s z' < 0)
//    would exert. The frozen wall particles have velocity 0, so the pair dissipation must grow by
//      kappa(h) = J1(h) / (h J0(h)),  J0 = int_cap w_D e_x^2 dV,  J1 = int_cap w_D e_x^2 d_z dV,
//    over the cap d_z > h of the unit sphere (w_D = (1 - r)^2). For a flat wall phi and h are
//    related one to one (phi(h) = int_cap W / int_sphere W), so kappa is tabulated as a function
//    of phi and looked up per particle: arbitrary geometries need no distance function.
//    gamma_eff = gamma_FW (1 + f (kappa - 1)), sigma_eff = sqrt(2 gamma_eff kBT) (fluctuation-
//    dissipation kept), with f = 1 for no slip and 0 <= f < 1 for partial slip.
//    kappa grows like 1/h at the surface; it is capped (kappa_max, default 5) so that the explicit
//    dissipation stays stable at dt = 0.01: with gamma = 4.5 and about 1.6 of summed w_D from
//    the wall, gamma kappa_max sum(w_D) dt = 0.36.
//
// Where this follows the paper and where it had to choose is listed in docs/walls.md.
#include <cstdint>
#include <vector>

#include "sim/hd.h"

namespace mesorock::sim {

// BVF weight W(r) = (1 - r)^2 for r < 1 (the dissipative weight, so the BVF sees the same
// neighbourhood the no-slip dissipation acts on).
template <class Real>
MESO_HD MESO_INLINE Real bvf_weight(Real r) {
  const Real s = Real(1) - r;
  return s * s;
}

// Device-copyable parameters of the wall model (pointers into host or device memory).
template <class Real>
struct WallModelView {
  std::uint32_t wall_mask = 0;  // bit t set: type t is wall
  Real phi_c = Real(0.5);       // penetration threshold
  bool bounce_back = false;     // reverse the whole velocity instead of its normal part
  Real slip_factor = Real(1);   // f: 1 = no slip, 0 = plain fluid-wall dissipation
  const Real* kappa = nullptr;  // kappa(phi) at phi = k / (entries - 1) * phi_max
  int entries = 0;
  Real phi_max = Real(0.5);  // table range; beyond it kappa = kappa(phi_max)

  MESO_HD MESO_INLINE bool is_wall(int type) const { return (wall_mask >> type) & 1u; }

  // Dissipation factor gamma_eff / gamma_FW for a fluid particle with BVF phi.
  MESO_HD MESO_INLINE Real dissipation_factor(Real phi) const {
    Real u = phi / phi_max * Real(entries - 1);
    if (u <= Real(0)) return Real(1) + slip_factor * (kappa[0] - Real(1));
    if (u >= Real(entries - 1)) return Real(1) + slip_factor * (kappa[entries - 1] - Real(1));
    const int k = static_cast<int>(u);
    const Real t = u - Real(k);
    const Real kap = kappa[k] + t * (kappa[k + 1] - kappa[k]);
    return Real(1) + slip_factor * (kap - Real(1));
  }
};

// Host side: the flat-wall relations phi(h) and kappa(h), and the tabulated kappa(phi).
struct FlatWallRelation {
  double phi = 0;    // BVF at distance h from a flat wall (equal number densities)
  double kappa = 1;  // no-slip dissipation factor J1 / (h J0)
};
FlatWallRelation flat_wall_relation(double h);

// kappa at `entries` equally spaced phi in [0, phi_max], capped at kappa_max.
std::vector<double> tabulate_kappa(int entries, double phi_max, double kappa_max);

// "Off": no wall model; every member the pass templates read is constexpr.
struct NoWallModel {
  static constexpr bool enabled = false;
  static constexpr const char* name = "off";
};

struct BoundaryVolumeFractionWalls {
  static constexpr bool enabled = true;
  static constexpr const char* name = "bvf";
};

}  // namespace mesorock::sim
