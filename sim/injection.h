#pragma once
// Injection and ejection boundaries (Xia et al. 2017, Phys. Fluids 29, 056601, Sec. IV B): one
// particle is injected at an inlet every `every` steps, and a particle found near the outlet is
// removed at the same rate, so the fluid's mass (and roughly its pressure) stays constant.
//
// With equal rates an injection and an ejection are one event on one particle: a particle picked
// at random among the ejectable types inside the outlet box is taken out and put back at a
// uniformly random point of the inlet box, as the injected type, with a Maxwell velocity at kBT
// and no force until the next force pass. The particle count never changes, so neither backend
// reallocates or renumbers anything, and ids stay unique.
//
// The pick is reproducible and backend-independent: every candidate gets the key
// hash(seed, step, event, pick, id) (Philox4x32-10) and the one with the smallest key moves; the
// new position and velocity are drawn from (seed, step, event, pick). Two candidates whose 64-bit
// keys tie would both move, on every backend alike (a chance of about N / 2^64 per pick).
//
// A scene without injection has count = 0: a host-side test per step, nothing per particle.
#include <cmath>
#include <cstdint>

#include <Random123/philox.h>

#include "sim/hd.h"

namespace mesorock::sim {

constexpr int kMaxInjections = 4;

// One injection/ejection boundary as the kernels read it.
template <class Real>
struct InjectionView {
  int inject_type = 0;
  std::uint32_t eject_types = 0;  // bit t: particles of type t may be taken at the outlet
  Real inlet_lo[3] = {0, 0, 0}, inlet_hi[3] = {0, 0, 0};
  Real outlet_lo[3] = {0, 0, 0}, outlet_hi[3] = {0, 0, 0};
  Real sqrt_kBT = 1;  // Maxwell velocities of injected particles (m = 1)
  std::uint64_t seed = 0;
  int index = 0;  // which boundary of the scene (keys the random streams)

  MESO_HD MESO_INLINE bool in_outlet(Real x, Real y, Real z) const {
    return x >= outlet_lo[0] && x < outlet_hi[0] && y >= outlet_lo[1] && y < outlet_hi[1] &&
           z >= outlet_lo[2] && z < outlet_hi[2];
  }
};

namespace detail {
// Philox4x32-10 of a counter (a, b, step) under a key (seed, salt).
MESO_HD MESO_INLINE r123::Philox4x32::ctr_type injection_draw(std::uint64_t seed,
                                                              std::uint32_t salt, std::uint32_t a,
                                                              std::uint32_t b, std::uint64_t step) {
  r123::Philox4x32 rng;
  r123::Philox4x32::ctr_type ctr = {
      {a, b, static_cast<std::uint32_t>(step), static_cast<std::uint32_t>(step >> 32)}};
  r123::Philox4x32::key_type key = {
      {static_cast<std::uint32_t>(seed) ^ salt, static_cast<std::uint32_t>(seed >> 32)}};
  return rng(ctr, key);
}
constexpr std::uint32_t kPickSalt = 0x1A7EC7u, kPlaceSalt = 0x9E3779B9u;
// u in (0, 1) from a 32-bit word.
MESO_HD MESO_INLINE double unit_open(std::uint32_t w) {
  return (static_cast<double>(w) + 0.5) * (1.0 / 4294967296.0);
}
}  // namespace detail

constexpr std::uint64_t kNoInjectionCandidate = ~std::uint64_t(0);

// The pick key of a particle at position (x, y, z) with type t and id: smaller moves first;
// kNoInjectionCandidate when the particle is not ejectable there.
template <class Real>
MESO_HD MESO_INLINE std::uint64_t injection_key(const InjectionView<Real>& inj, Real x, Real y,
                                                Real z, int type, std::int64_t id,
                                                std::uint64_t step, int pick) {
  if (!((inj.eject_types >> type) & 1u) || !inj.in_outlet(x, y, z)) return kNoInjectionCandidate;
  const std::uint64_t u = static_cast<std::uint64_t>(id);
  const auto out = detail::injection_draw(
      inj.seed,
      detail::kPickSalt ^ (static_cast<std::uint32_t>(inj.index) << 24) ^
          static_cast<std::uint32_t>(pick),
      static_cast<std::uint32_t>(u), static_cast<std::uint32_t>(u >> 32), step);
  const std::uint64_t key = (static_cast<std::uint64_t>(out.v[0]) << 32) | out.v[1];
  return key == kNoInjectionCandidate ? key - 1 : key;
}

// Where and how fast the particle of pick `pick` at `step` re-enters: a uniform point of the inlet
// box and a Maxwell velocity (Box-Muller on four uniforms).
template <class Real>
MESO_HD MESO_INLINE void injection_placement(const InjectionView<Real>& inj, std::uint64_t step,
                                             int pick, Real pos[3], Real vel[3]) {
  const std::uint32_t salt = detail::kPlaceSalt ^ (static_cast<std::uint32_t>(inj.index) << 24);
  const auto a = detail::injection_draw(inj.seed, salt, static_cast<std::uint32_t>(pick), 0u, step);
  const auto b = detail::injection_draw(inj.seed, salt, static_cast<std::uint32_t>(pick), 1u, step);
  for (int k = 0; k < 3; ++k) {
    const double u = detail::unit_open(a.v[k]);
    pos[k] = inj.inlet_lo[k] + static_cast<Real>(u) * (inj.inlet_hi[k] - inj.inlet_lo[k]);
    if (!(pos[k] < inj.inlet_hi[k])) pos[k] = inj.inlet_lo[k];  // rounding at the upper face
  }
  constexpr double kTwoPi = 6.283185307179586;
  const double r1 = std::sqrt(-2.0 * std::log(detail::unit_open(a.v[3])));
  const double r2 = std::sqrt(-2.0 * std::log(detail::unit_open(b.v[0])));
  const double t1 = kTwoPi * detail::unit_open(b.v[1]);
  const double t2 = kTwoPi * detail::unit_open(b.v[2]);
  vel[0] = static_cast<Real>(r1 * std::cos(t1)) * inj.sqrt_kBT;
  vel[1] = static_cast<Real>(r1 * std::sin(t1)) * inj.sqrt_kBT;
  vel[2] = static_cast<Real>(r2 * std::cos(t2)) * inj.sqrt_kBT;
}

// One boundary as an engine runs it: the kernels' view and when its events fall.
template <class Real>
struct InjectionPlan {
  InjectionView<Real> view;
  std::uint64_t every = 1, start_step = 0, stop_step = ~std::uint64_t(0);
  int per_event = 1;
  bool due(std::uint64_t step) const {
    return step > start_step && step <= stop_step && step % every == 0;
  }
};

// Host-side counters of one boundary: particles moved, and events that found no candidate in the
// outlet box (then nothing moves: the rate falls short, and the report says so).
struct InjectionCounts {
  std::uint64_t injected = 0;
  std::uint64_t missed = 0;
};

}  // namespace mesorock::sim
