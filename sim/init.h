#pragma once
// Initial particle placement and velocities. Every random choice is keyed by a seed through the
// counter-based generator, so the same inputs and seed give the same particles on any machine.
#include <array>
#include <cstdint>

#include "sim/model.h"

namespace mesorock::sim {

// Uniform random variate in [0, 1) from (seed, stream, index, component): reproducible, and
// independent of the order in which particles are generated.
double seeded_uniform(std::uint64_t seed, std::uint64_t stream, std::uint64_t index,
                      std::uint32_t component);
// Standard normal variate (Box-Muller over two seeded_uniform draws).
double seeded_normal(std::uint64_t seed, std::uint64_t stream, std::uint64_t index,
                     std::uint32_t component);

// Appends `count` particles of `type` at uniformly random positions in [lo, hi).
// Ids continue from next_id (which is advanced). Velocities are zero.
void fill_random(ParticleSet& p, std::int32_t type, const std::array<double, 3>& lo,
                 const std::array<double, 3>& hi, std::int64_t count, std::uint64_t seed,
                 std::int64_t& next_id);

// Appends particles of `type` on a simple cubic lattice with number density close to `density`
// filling [lo, hi) (spacing adapted per axis so the lattice tiles the region exactly).
void fill_lattice(ParticleSet& p, std::int32_t type, const std::array<double, 3>& lo,
                  const std::array<double, 3>& hi, double density, std::int64_t& next_id);

// Maxwell-Boltzmann velocities at kBT (m = 1) for mobile particles; the centre-of-mass velocity
// of the mobile particles is removed. Frozen types get zero velocity.
void assign_maxwell_velocities(ParticleSet& p, const Model& model, double kBT, std::uint64_t seed);

}  // namespace mesorock::sim
