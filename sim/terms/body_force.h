#pragma once
// Body force per particle (m = 1), applied after the pair loop: F = s(x) g_type, where the sign
// s depends on the position only for the reverse-Poiseuille profile. Its parameters are per
// type (TypeSpec::body_force), not per pair. Scene: [[types]] body_force, model.body_force_profile.
#include "sim/hd.h"
#include "sim/model.h"

namespace mesorock::sim {

struct NoBodyForce {
  static constexpr bool enabled = false;
  static constexpr const char* name = "off";
  static bool matches(const Model& m) { return !m.has_body_force(); }
};

// s = 1: a uniform pressure gradient (or gravity) per type.
struct PerTypeBodyForce {
  static constexpr bool enabled = true;
  static constexpr const char* name = "per-type";
  static bool matches(const Model& m) {
    return m.has_body_force() && m.body_force_profile == BodyForceProfile::Uniform;
  }
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
  static bool matches(const Model& m) {
    return m.has_body_force() && m.body_force_profile == BodyForceProfile::Reversed;
  }
  template <class Real>
  MESO_HD static MESO_INLINE Real sign(Real coordinate, Real midplane) {
    return coordinate < midplane ? Real(1) : Real(-1);
  }
};

}  // namespace mesorock::sim
