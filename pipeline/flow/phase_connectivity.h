#pragma once
// Whether a liquid phase spans a sample along the flow axis: the connectivity behind a phase's
// relative permeability (a phase whose clusters do not span the sample cannot carry a steady flux
// through it, only drift with the other). `rockflow relperm` reports it for every run.
//
// Two particles of the phase are bonded when they lie closer than `cutoff` (minimum image). In a
// dense liquid the first neighbour shell lies within about 0.6 rc, so 0.7 rc bonds a phase to
// itself, while two particles of one phase on either side of a layer of the other are about 1 rc
// apart and stay unbonded. Clusters by union-find with each particle's unwrapped offset from its
// root along the axis: along a periodic axis a cluster spans the sample when a bond closes a loop
// around the box (the offsets it joins differ by a box length); along a bounded axis when it holds
// particles within `cutoff` of both faces.
#include <cstddef>

#include "sim/model.h"

namespace mesorock::pipeline {

struct PhaseConnectivity {
  std::size_t particles = 0;  // of the phase
  std::size_t clusters = 0;
  std::size_t largest = 0;       // particles in the largest cluster
  bool spans = false;            // some cluster spans the sample along the axis
  double spanning_fraction = 0;  // share of the phase's particles in spanning clusters
};

PhaseConnectivity phase_connectivity(const sim::ParticleSet& particles, int type,
                                     const sim::BoxSpec& box, int axis, double cutoff = 0.7);

}  // namespace mesorock::pipeline
