#pragma once
// A Simulation over several ranks (MPI), each owning the particles in its region of the box
// (sim/domain/decomposition.h), exchanging ghosts every step (sim/domain/exchange.h) and
// re-balancing by RCB on the measured cost. make_simulation() builds one when its options carry a
// communicator of more than one rank; every call on it is collective.
#include <memory>

#include "sim/simulation.h"

namespace mesorock::sim {

std::unique_ptr<Simulation> make_distributed_simulation(const Model& model, const BoxSpec& box,
                                                        const ParticleSet& particles, double dt,
                                                        const SimulationOptions& options);
// Continues a run from a saved state (sim/checkpoint.h) of a run on any number of ranks, one
// included: each rank takes the saved particles in its region with their velocities and forces.
// resume_simulation calls it after checking that the state fits the model.
std::unique_ptr<Simulation> resume_distributed_simulation(const Model& model, const BoxSpec& box,
                                                          const SimulationState& state,
                                                          const SimulationOptions& options);

}  // namespace mesorock::sim
