#pragma once
// The checks make_simulation and resume_simulation run on their inputs (sim/validate_inputs.cpp),
// one per spec of the model; each throws ConfigError naming the first problem it finds.
#include <cstddef>
#include <cstdint>

#include "sim/model.h"

namespace mesorock::sim {

// Everything: types and pairs, dt, solid grid, box, wall model, virtual walls, rigid slabs,
// injections, particles. step: the step the particles are at (a resumed run; a virtual wall
// lifted before it checks nothing).
void validate_inputs(const Model& model, const BoxSpec& box, const ParticleSet& particles,
                     double dt, std::uint64_t step = 0);

// The wall model (WallModelSpec), when enabled: its parameters, frozen wall types, the thermostat
// it acts through. The message starts with the scene key ("walls.slip_factor: ..."); the scene
// reader prefixes its file name.
void validate_wall_model(const Model& model);

// Rigid slab k of the model (RigidSlabSpec): a mobile type, not a wall, listed once, an axis and a
// finite pressure. Messages as for the wall model ("slabs[0].type: ...").
void validate_rigid_slab(const Model& model, std::size_t k);

// Injection boundary k of the model (InjectionSpec): mobile types, inlet and outlet boxes inside
// the box and apart, event interval, count and steps. The message starts with the scene key
// ("injection[0].type: ..."); the scene reader prefixes its file name.
void validate_injection(const Model& model, const BoxSpec& box, std::size_t k);

}  // namespace mesorock::sim
