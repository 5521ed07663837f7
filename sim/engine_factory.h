#pragma once
// How a Simulation (sim/simulation.cpp) starts on each rank: input validation, the host state
// built from the model and the particles, and the engine of the chosen backend. The decomposed
// Domain (sim/domain/distributed.cpp) builds its ranks' states with these too.
#include <memory>

#include "sim/simulation.h"
#include "sim/state.h"
#include "sim/validate_inputs.h"

namespace mesorock::sim {

// Fills the host state (pair table, effects, box, cell grid, particles in the run's precision).
template <class Real>
void init_host_state(HostState<Real>& state, const Model& model, const BoxSpec& box,
                     const ParticleSet& particles, double dt, const SimulationOptions& options);

// The engine of options.backend for the model's compiled term set.
template <class Real>
std::unique_ptr<Engine<Real>> make_engine(const Model& model, const SimulationOptions& options);

}  // namespace mesorock::sim
