#pragma once
// Rigid slabs (pistons): every particle of a slab type moves with one velocity V along the slab's
// axis, the rigid body's, under the pair forces from the fluid plus an applied force P A (P the
// applied pressure, A the box's cross-section perpendicular to the axis; P > 0 pushes towards
// +axis). The 2020 paper's flooding set-up has a pushing slab and a back-pressure slab.
//
// Velocity Verlet for the body, M = number of slab particles (m = 1):
//   V(t + dt/2) = V(t) + dt/2 F(t) / M;   x_i += dt V(t + dt/2) for each slab particle;
//   forces;  F(t + dt) = sum_i f_i . e_axis + P A;   V(t + dt) = V(t + dt/2) + dt/2 F(t + dt) / M.
// The slab particles' own velocities (and v~, for the dissipative force) are V e_axis: a slab
// has no thermal motion and is left out of the temperature. A scene without slabs has count = 0:
// one uniform compare per particle in the two kicks, and no reduction.
#include <cstdint>

#include "sim/hd.h"

namespace mesorock::sim {

constexpr int kMaxRigidSlabs = 4;

template <class Real>
struct RigidSlabs {
  int count = 0;
  std::uint32_t mask = 0;  // bit t: type t is a slab
  int type[kMaxRigidSlabs] = {0, 0, 0, 0};
  int axis[kMaxRigidSlabs] = {0, 0, 0, 0};
  // V(t + dt/2) for the drift and V(t + dt) for the second kick, one per slab (host or device).
  const Real* half_velocity = nullptr;
  const Real* velocity = nullptr;

  MESO_HD MESO_INLINE bool is_slab(int t) const { return (mask >> t) & 1u; }
  MESO_HD MESO_INLINE int slab_of(int t) const {
    for (int k = 0; k < count; ++k)
      if (type[k] == t) return k;
    return -1;
  }
};

// Host-side state of one slab's rigid body, double precision.
struct RigidSlabBody {
  int type = 0;
  int axis = 0;
  double applied_force = 0;  // P A along +axis
  double mass = 0;           // particles in the slab
  double velocity = 0;       // V(t)
  double half_velocity = 0;  // V(t + dt/2) of the current step
  double force = 0;          // F(t): pair forces along the axis + applied force
};

// The body's two half kicks (shared by the CPU engine and the CUDA engine's one-thread kernels).
MESO_HD MESO_INLINE void slab_half_kick(RigidSlabBody& b, double dt) {
  b.half_velocity = b.velocity + 0.5 * dt * b.force / b.mass;
}
// pair_force: the sum over the slab's particles of their forces along the axis.
MESO_HD MESO_INLINE void slab_set_force(RigidSlabBody& b, double pair_force) {
  b.force = pair_force + b.applied_force;
}
MESO_HD MESO_INLINE void slab_full_kick(RigidSlabBody& b, double dt) {
  b.velocity = b.half_velocity + 0.5 * dt * b.force / b.mass;
}

}  // namespace mesorock::sim
