#pragma once
// The arbitrary-geometry wall model of Li, Bian, Tang & Karniadakis, "A dissipative particle
// dynamics method for arbitrarily complex geometries", J. Comput. Phys. 355 (2018) 534-547
// (arXiv 1612.08761), as used by the 2020 paper for pore walls made of frozen particles. The
// formulas follow the authors' own implementation (LAMMPS fix solidwall/mdpd, pair
// mdpd/solidwall; USER-MESO fix aboundary/rho/meso), which cites this paper; docs/walls.md lists
// where mesorock chose otherwise and why.
//
// Three parts, all local to a fluid particle i and its neighbours within rc = 1:
//
// 1. Boundary volume fraction (BVF): the share of i's support that is wall,
//      phi_i = (1 / n_w) sum_{j in wall} W(r_ij),  W(r) = 105 / (16 pi) (1 + 3r) (1 - r)^3,
//    with W the Lucy kernel (its integral over the unit ball is 1) and n_w the wall's number
//    density. 0 in the bulk fluid, 1/2 on a flat wall surface, 1 inside a wall thicker than rc.
//    The wall-side normal is n_i = -grad phi / |grad phi|, along
//      sum_{j in wall} r_ij (1 - r_ij)^2 e_ij   (e_ij from the wall particle j towards i).
//
// 2. Penetration and the predictor-corrector: after the drift x(t+dt) = x(t) + dt v (the
//    predictor, v the half-step velocity), a fluid particle with phi_i > phi_c has entered the
//    wall; its drift is redone from x(t) with
//      v' = -v + 2 max(0, v . n) n
//    (a particle moving into the wall returns along its path; one already leaving keeps its
//    normal velocity and reverses its tangential one), so x(t+dt) = x_predicted + dt (v' - v).
//    phi_c = 1/2: the flat-wall surface.
//
// 3. No slip through an effective fluid-wall dissipation. A particle at distance h from a flat
//    wall in a linear shear flow u = s z (no slip at z = 0) should feel from the wall region the
//    dissipative force that fluid continuing the profile below the wall (velocity s z' < 0)
//    would exert. The frozen wall particles have velocity 0, so the pair dissipation must grow by
//      kappa(h) = J1(h) / (h J0(h)),  J0 = int_cap w_D e_x^2 dV,  J1 = int_cap w_D e_x^2 d_z dV,
//    over the cap d_z > h of the unit sphere (w_D = (1 - r)^2). For a flat wall phi and h are
//    related one to one (phi(h) = int_cap W), so kappa is tabulated as a function of phi and
//    looked up per particle: arbitrary geometries need no distance function.
//    gamma_eff = gamma_FW (1 + f (kappa - 1)), sigma_eff = sqrt(2 gamma_eff kBT) (fluctuation-
//    dissipation kept), with f = 1 for no slip and 0 <= f < 1 for partial slip (mesorock's
//    option; the authors' code has no slip parameter). kappa grows like 1/h at the surface; as
//    in the authors' code h is floored at 0.025 rc, which caps kappa at 8.2.
#include <cstdint>
#include <vector>

#include "sim/hd.h"

namespace mesorock::sim {

// BVF weight: the Lucy kernel with support rc = 1, W(r) = 105 / (16 pi) (1 + 3r) (1 - r)^3.
template <class Real>
MESO_HD MESO_INLINE Real bvf_weight(Real r) {
  const Real s = Real(1) - r;
  return Real(105.0 / (16.0 * 3.14159265358979323846)) * (Real(1) + 3 * r) * s * s * s;
}

// Magnitude of the BVF gradient direction of one wall neighbour, -dW/dr / (315 / (4 pi)):
// r (1 - r)^2 (only the direction of the sum is used).
template <class Real>
MESO_HD MESO_INLINE Real bvf_normal_weight(Real r) {
  const Real s = Real(1) - r;
  return r * s * s;
}

// How the corrector turns a penetrating particle around: the authors' v' = -v + 2 max(0, v.n) n,
// or the specular v' = v - 2 min(0, v.n) n (Li et al.'s earlier variant; normal part only).
enum class WallReflection : int { Li2018 = 0, Specular = 1 };
inline const char* to_string(WallReflection r) {
  return r == WallReflection::Li2018 ? "li2018" : "specular";
}

// Device-copyable parameters of the wall model (pointers into host or device memory).
template <class Real>
struct WallModelView {
  std::uint32_t wall_mask = 0;          // bit t set: type t is wall
  Real inv_wall_density = Real(0.125);  // 1 / n_w
  Real phi_c = Real(0.5);               // penetration threshold
  WallReflection reflection = WallReflection::Li2018;
  Real slip_factor = Real(1);   // f: 1 = no slip, 0 = plain fluid-wall dissipation
  const Real* kappa = nullptr;  // kappa(phi) at phi = k / (entries - 1) * phi_max
  int entries = 0;
  Real phi_max = Real(0.5);  // table range; beyond it kappa = kappa(phi_max)

  MESO_HD MESO_INLINE bool is_wall(int type) const { return (wall_mask >> type) & 1u; }

  // Dissipation factor gamma_eff / gamma_FW for a fluid particle with BVF phi.
  MESO_HD MESO_INLINE Real dissipation_factor(Real phi) const {
    Real u = phi / phi_max * Real(entries - 1);
    // !(u > 0) also catches a NaN phi, which would otherwise index the table out of range.
    if (!(u > Real(0))) return Real(1) + slip_factor * (kappa[0] - Real(1));
    if (u >= Real(entries - 1)) return Real(1) + slip_factor * (kappa[entries - 1] - Real(1));
    const int k = static_cast<int>(u);
    const Real t = u - Real(k);
    const Real kap = kappa[k] + t * (kappa[k + 1] - kappa[k]);
    return Real(1) + slip_factor * (kap - Real(1));
  }
};

// Host side: the flat-wall relations phi(h) and kappa(h), and the tabulated kappa(phi).
struct FlatWallRelation {
  double phi = 0;    // BVF at distance h from a flat wall of density n_w
  double kappa = 1;  // no-slip dissipation factor J1 / (h J0)
};
FlatWallRelation flat_wall_relation(double h);

// The closed form of phi(h) for the Lucy kernel (x = h / rc):
// 1/2 - 21/16 x + 35/16 x^3 - 63/16 x^5 + 7/2 x^6 - 15/16 x^7; 0 for x >= 1.
double flat_wall_phi(double h);

// The authors' floor of the wall distance in the dissipation factor: kappa(0.025) = 8.2.
constexpr double kMinWallDistance = 0.025;

// kappa at `entries` equally spaced phi in [0, phi_max], capped at kappa_max.
std::vector<double> tabulate_kappa(int entries, double phi_max, double kappa_max);

// Virtual walls (sim/kernels.h apply_virtual_walls), device-copyable: at most kMaxVirtualWalls.
constexpr int kMaxVirtualWalls = 4;
template <class Real>
struct VirtualWalls {
  int count = 0;
  int axis[kMaxVirtualWalls] = {0, 0, 0, 0};
  Real position[kMaxVirtualWalls] = {0, 0, 0, 0};
  std::uint32_t type_mask[kMaxVirtualWalls] = {0, 0, 0, 0};
  bool keep_below[kMaxVirtualWalls] = {true, true, true, true};
  std::uint64_t until_step[kMaxVirtualWalls] = {0, 0, 0, 0};
};

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
