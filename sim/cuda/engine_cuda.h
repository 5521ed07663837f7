#pragma once
// The CUDA backend: the same kernel bodies as the CPU backend (sim/kernels.h), one thread per
// particle; the whole step stays on the device.
#include <memory>

#include "sim/model.h"
#include "sim/state.h"

namespace mesorock::sim {

// frozen_part: SimulationOptions::frozen_part.
template <class Real>
std::unique_ptr<Engine<Real>> make_cuda_engine(const Model& model, int device, bool profile,
                                               bool frozen_part);

}  // namespace mesorock::sim
