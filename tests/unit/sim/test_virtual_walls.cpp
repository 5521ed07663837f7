// Virtual walls (sim/kernels.h apply_virtual_walls): a plane keeps the particles of the blocked
// types on their side while it is active, lets every other type through, and lets the blocked
// ones through once it is removed. One body for every backend.
#include <gtest/gtest.h>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct FluidPair {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// Standard DPD fluid (fast to equilibrate) of two types in a 10 x 4 x 4 box, reflective in x;
// "kept" starts below x = 5, "free" everywhere; both pushed along +x.
FluidPair two_fluids(std::uint64_t until_step) {
  FluidPair s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.seed = 21;
  const int kept = s.model.add_type({"kept", false, {0.3, 0, 0}});
  const int free = s.model.add_type({"free", false, {0.3, 0, 0}});
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) s.model.set_pair(a, b, {25, 0, 4.5});
  s.model.virtual_walls.push_back({0, 5.0, 1u << kept, true, until_step});
  s.box.hi = {10, 4, 4};
  s.box.periodic = {false, true, true};
  std::int64_t next = 0;
  ms::fill_random(s.particles, kept, {0, 0, 0}, {5, 4, 4}, 240, 21, next);
  ms::fill_random(s.particles, free, {0, 0, 0}, {10, 4, 4}, 240, 22, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 21);
  return s;
}

int count_above(const ms::ParticleSet& p, int type, double x) {
  int n = 0;
  for (size_t i = 0; i < p.size(); ++i) n += p.type[i] == type && p.x[i] >= x;
  return n;
}

class VirtualWall : public OnEveryBackend {};

TEST_P(VirtualWall, KeepsItsTypesBackUntilItIsRemoved) {
  FluidPair s = two_fluids(300);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  int free_above_start = count_above(sim->particles(), 1, 5.0);
  for (int k = 0; k < 6; ++k) {
    sim->run(50);
    EXPECT_EQ(count_above(sim->particles(), 0, 5.0), 0) << "step " << sim->step();
  }
  // The free type is pushed against the far face meanwhile.
  EXPECT_GT(count_above(sim->particles(), 1, 5.0), free_above_start);
  sim->run(600);
  EXPECT_GT(count_above(sim->particles(), 0, 5.0), 20) << "the wall is removed at step 300";
}

TEST_P(VirtualWall, RefusesParticlesOnTheBlockedSideAndWallsOutsideTheBox) {
  FluidPair s = two_fluids(100);
  s.particles.x[0] = 6.0;  // a kept particle above the plane
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = two_fluids(100);
  s.model.virtual_walls[0].position = 12.0;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = two_fluids(0);  // never active: a particle may start anywhere
  s.particles.x[0] = 6.0;
  EXPECT_NO_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()));
}

MESOROCK_ON_EVERY_BACKEND(VirtualWall);

}  // namespace
