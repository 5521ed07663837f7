#pragma once
// The CUDA backend: the same kernel bodies as the CPU backend (sim/kernels.h), one thread per
// particle; the whole step stays on the device.
#include <memory>

#include "sim/model.h"
#include "sim/state.h"

namespace mesorock::sim {

// graphs: replay a captured step as a CUDA graph where the step allows it (SimulationOptions).
template <class Real>
std::unique_ptr<Engine<Real>> make_cuda_engine(const Model& model, int device, bool profile,
                                               bool graphs = true);

}  // namespace mesorock::sim
