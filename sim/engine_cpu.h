#pragma once
#include <memory>

#include "sim/model.h"
#include "sim/state.h"

namespace mesorock::sim {

struct CpuEngineOptions {
  int threads = 0;          // OpenMP threads; <= 0: OpenMP's default
  bool frozen_part = true;  // SimulationOptions::frozen_part
  bool buried_part = true;  // SimulationOptions::buried_part
};

// The CPU backend: OpenMP loops over the shared kernel bodies.
template <class Real>
std::unique_ptr<Engine<Real>> make_cpu_engine(const Model& model, const CpuEngineOptions& options);

}  // namespace mesorock::sim
