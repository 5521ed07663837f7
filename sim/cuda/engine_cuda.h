#pragma once
// The CUDA backend: the same kernel bodies as the CPU backend (sim/kernels.h), one thread per
// particle; the whole step stays on the device.
#include <memory>

#include "sim/model.h"
#include "sim/state.h"

namespace mesorock::sim {

// SimulationOptions' CUDA choices (sim/simulation.h).
struct CudaEngineOptions {
  int device = 0;
  bool profile = false;
  bool frozen_part = true;
  bool buried_part = true;
  bool graphs = true;
  int lanes = 0;
  bool penetration_mask = true;
  bool frozen_density_list = true;
};

template <class Real>
std::unique_ptr<Engine<Real>> make_cuda_engine(const Model& model, const CudaEngineOptions& o);

}  // namespace mesorock::sim
