#pragma once
#include <memory>

#include "sim/model.h"
#include "sim/state.h"

namespace mesorock::sim {

// The CPU backend: OpenMP loops over the shared kernel bodies. threads <= 0: OpenMP's default.
// frozen_part: SimulationOptions::frozen_part.
template <class Real>
std::unique_ptr<Engine<Real>> make_cpu_engine(const Model& model, int threads,
                                              bool frozen_part = true);

}  // namespace mesorock::sim
