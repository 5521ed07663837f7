#pragma once
// The host-side sums behind the Simulation observables (sim/simulation.cpp): each rank sums over
// its own particles, and the Domain's communicator sums the ranks (one rank: nothing to add).
// Frozen types and rigid slabs are never counted: their velocities are not thermal. Internal to
// sim/.
#include <array>
#include <cstdint>

#include "mesorock/errors.h"
#include "sim/kernels.h"
#include "sim/observables.h"
#include "sim/simulation.h"
#include "sim/state.h"

namespace mesorock::sim {

// Over the mobile particles `counted(i)` accepts: sum of v^2, their number and sum of v.
struct MobileSums {
  double v2 = 0, count = 0;
  std::array<double, 3> p{0, 0, 0};
};

template <class Real, class Counted>
MobileSums mobile_sums(const HostState<Real>& s, Counted&& counted) {
  MobileSums m;
  const std::uint32_t skip = s.frozen_mask | s.slabs.mask;
  for (int i = 0; i < s.size(); ++i) {
    if (((skip >> s.type[i]) & 1u) || !counted(i)) continue;
    const double v[3] = {double(s.vx[i]), double(s.vy[i]), double(s.vz[i])};
    m.v2 += v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    m.count += 1;
    for (int a = 0; a < 3; ++a) m.p[static_cast<size_t>(a)] += v[a];
  }
  return m;
}

// The leak invariant over the particles `counted(i)` accepts, skipping frozen types and slabs.
// Serial, so the deepest particle (ties: the smaller id) does not depend on the thread count.
template <class Real, class Counted>
SolidIntrusion solid_intrusion_of(const HostState<Real>& s, Counted&& counted) {
  SolidIntrusion r;
  if (!s.solid.enabled()) return r;
  r.available = true;
  const std::uint32_t skip = s.frozen_mask | s.slabs.mask;
  for (int i = 0; i < s.size(); ++i) {
    if (((skip >> s.type[i]) & 1u) || !counted(i) || !s.solid.in_solid(s.x[i], s.y[i], s.z[i]))
      continue;
    ++r.inside;
    const double d = double(s.solid.depth(s.x[i], s.y[i], s.z[i]));
    if (r.deepest_id < 0 || d > r.max_depth || (d == r.max_depth && s.id[i] < r.deepest_id)) {
      r.max_depth = d;
      r.deepest_id = s.id[i];
      r.deepest_position = {double(s.x[i]), double(s.y[i]), double(s.z[i])};
    }
  }
  return r;
}

// The kinetic stress sums sum m v^a v^b (Voigt order, not yet over a volume) of the mobile
// particles in `region` (ghosts are never in it). `s` is not const because HostState::view() is
// not.
template <class Real>
std::array<double, 6> kinetic_stress_sums(HostState<Real>& s, const VirialRegion<Real>& region) {
  std::array<double, 6> k{};
  const std::uint32_t skip = s.frozen_mask | s.slabs.mask;
  const StepView<Real> view = s.view();
  for (int i = 0; i < s.size(); ++i) {
    if (((skip >> s.type[i]) & 1u) || !region.contains(view, i)) continue;
    const double v[3] = {double(s.vx[i]), double(s.vy[i]), double(s.vz[i])};
    k[0] += v[0] * v[0], k[1] += v[1] * v[1], k[2] += v[2] * v[2];
    k[3] += v[0] * v[1], k[4] += v[0] * v[2], k[5] += v[1] * v[2];
  }
  return k;
}

// The virial region of a selection, and its volume; ConfigError unless hi > lo on every axis.
template <class Real>
VirialRegion<Real> virial_region_of(const RegionSelection& r, double* volume) {
  VirialRegion<Real> region;
  region.active = true;
  region.type_mask = r.type_mask;
  *volume = 1;
  for (int a = 0; a < 3; ++a) {
    if (!(r.hi[a] > r.lo[a])) throw ConfigError("region stress: hi must exceed lo on every axis");
    region.lo[a] = static_cast<Real>(r.lo[a]);
    region.hi[a] = static_cast<Real>(r.hi[a]);
    *volume *= r.hi[a] - r.lo[a];
  }
  return region;
}

inline void check_bin_grid(const BinGrid& grid) {
  for (int a = 0; a < 3; ++a)
    if (grid.cells[static_cast<size_t>(a)] < 1 || !(grid.width(a) > 0))
      throw ConfigError("bins: every axis needs at least one bin of positive width");
}

}  // namespace mesorock::sim
