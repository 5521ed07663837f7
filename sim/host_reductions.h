#pragma once
// Host-side helpers of the Simulation observables (sim/simulation.cpp). The sums themselves are
// the engines' (Engine::solid_intrusion, slab_bodies, virial, bin_sums: on the GPU where the
// particles are); each rank sums its own particles and the Domain's communicator sums the ranks.
// Internal to sim/.

#include "mesorock/errors.h"
#include "sim/kernels.h"
#include "sim/observables.h"
#include "sim/simulation.h"
#include "sim/state.h"

namespace mesorock::sim {

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
