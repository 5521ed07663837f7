// Rigid slabs (pistons, sim/rigid_slabs.h): a slab pushed with pressure P onto a DPD fluid
// compresses it until the fluid's pressure balances P. With P = 23.65, Groot & Warren's measured
// pressure of the a = 25 fluid at rho = 3 (the eos-dpd case's reference), the bulk settles at
// rho = 3. One body for every backend.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct Piston {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// Box x in [0, 12] with reflective x faces, 4 x 4 periodic in y and z. 384 fluid particles start
// at random in [0, 8.4] (rho 2.86; rho 3 would fill [0, 8]); the slab, a lattice of density 6 in
// x in [8.6, 10.1], is pushed towards -x. (Started further from equilibrium, the piston rings:
// the fluid column is a spring of about 100 kBT/rc^2 that the DPD dissipation damps only over
// thousands of steps.)
Piston piston(double pressure) {
  Piston s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.seed = 17;
  const int fluid = s.model.add_type({"fluid", false, {0, 0, 0}});
  const int slab = s.model.add_type({"slab", false, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {25, 0, 4.5});
  s.model.set_pair(fluid, slab, {25, 0, 4.5});
  s.model.set_pair(slab, slab, {0, 0, 0});
  s.model.rigid_slabs.push_back({slab, 0, pressure});
  s.box.hi = {12, 4, 4};
  s.box.periodic = {false, true, true};
  std::int64_t next = 0;
  ms::fill_random(s.particles, fluid, {0, 0, 0}, {8.4, 4, 4}, 384, 17, next);
  ms::fill_lattice(s.particles, slab, {8.6, 0, 0}, {10.1, 4, 4}, 6, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 17);
  return s;
}

class RigidSlab : public OnEveryBackend {};

TEST_P(RigidSlab, PistonCompressesTheFluidToThePressureItApplies) {
  Piston s = piston(-23.65);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  // The piston rings after the start: the fluid column is a spring of about 100 kBT/rc^2 with a
  // period of about 10 time units, and sound of that wavelength decays over some 130 (bulk
  // viscosity). 15,000 steps let it settle.
  sim->run(15000);
  double rho = 0, slab_x = 0, slab_v = 0;
  int samples = 0, leaked = 0;
  for (int k = 0; k < 40; ++k) {
    sim->run(50);
    const ms::ParticleSet p = sim->particles();
    int bulk = 0;
    const auto slabs = sim->rigid_slabs();
    ASSERT_EQ(slabs.size(), 1u);
    for (size_t i = 0; i < p.size(); ++i) {
      if (p.type[i] != 0) continue;
      if (p.x[i] > 2 && p.x[i] < 5) ++bulk;
      if (p.x[i] > slabs[0].position) ++leaked;
    }
    rho += bulk / (3.0 * 16.0);
    slab_x += slabs[0].position;
    slab_v += std::abs(slabs[0].velocity);
    ++samples;
  }
  rho /= samples;
  slab_x /= samples;
  slab_v /= samples;
  std::printf("piston at P = 23.65: bulk density %.4f, slab at x = %.3f, mean |V| %.4f\n", rho,
              slab_x, slab_v);
  EXPECT_NEAR(rho, 3.0, 0.09) << "Groot & Warren: p(rho = 3) = 23.65 for a = 25";
  EXPECT_LT(slab_x, 9.3) << "the slab moved in (it started at 9.35)";
  EXPECT_EQ(leaked, 0) << "fluid particles got past the slab";
  EXPECT_LT(slab_v, 0.15) << "thermal: sqrt(kBT / M) = 0.08 for M = 144";
  // The slab's particles move as one body: equal velocities, none across the axis.
  // Its position is the mean of its particles' (summed by the engine, on the GPU where they are).
  const ms::ParticleSet p = sim->particles();
  const double V = sim->rigid_slabs()[0].velocity;
  double x_sum = 0, count = 0;
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == 1) {
      ASSERT_NEAR(p.vx[i], V, 1e-6 * (1 + std::abs(V)));
      ASSERT_EQ(p.vy[i], 0.0);
      ASSERT_EQ(p.vz[i], 0.0);
      x_sum += p.x[i];
      count += 1;
    }
  EXPECT_NEAR(sim->rigid_slabs()[0].position, x_sum / count, 1e-9);
}

TEST_P(RigidSlab, RefusesFrozenOrEmptySlabs) {
  Piston s = piston(-1);
  s.model.types[1].frozen = true;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = piston(-1);
  s.model.rigid_slabs[0].type = 0;
  s.model.rigid_slabs.push_back({0, 0, 1.0});
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  // The sim's check (sim::validate_rigid_slab) names the scene key, as the scene reader shows it.
  s = piston(-1);
  s.model.rigid_slabs[0].applied_pressure = std::nan("");
  try {
    ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    ADD_FAILURE() << "a NaN slab pressure was accepted";
  } catch (const mesorock::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "slabs[0].pressure: must be finite (got nan)");
  }
}

MESOROCK_ON_EVERY_BACKEND(RigidSlab);

}  // namespace

// Which types move freely: one definition (Model::mobile_mask) for injection, the sweep's driven
// types, the binned observables' default types and the parser.
TEST(Model, MobileTypesAreNeitherFrozenNorSlabBodies) {
  ms::Model m;
  m.types = {{"water"}, {"wall", true}, {"piston"}, {"oil"}};
  m.rigid_slabs.push_back({2, 2, -1.0});
  EXPECT_EQ(m.frozen_mask(), 0b0010u);
  EXPECT_EQ(m.mobile_mask(), 0b1001u);
  EXPECT_TRUE(m.is_mobile(0));
  EXPECT_FALSE(m.is_mobile(1));
  EXPECT_FALSE(m.is_mobile(2));
  EXPECT_TRUE(m.is_mobile(3));
  EXPECT_FALSE(m.is_mobile(4));       // no such type
  EXPECT_EQ(m.wall_mask(), 0b0010u);  // the wall model's walls: every frozen type by default
  m.wall_model.wall_types = 0b0100u;
  EXPECT_EQ(m.wall_mask(), 0b0100u);
}
