// Reorder interval and skin (SimulationOptions::reorder_every, skin): between sorts the cell list
// is stale, yet no pair within rc is missed (cells of rc + skin, a re-sort when any particle has
// moved skin / 2, minimum images across periodic faces). One body for every backend.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct Box {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// mDPD liquid without the thermostat (forces depend on positions only), double precision, a
// small periodic box (4 cells of rc + skin per axis) so particles cross its faces often.
Box liquid() {
  Box s;
  s.model.seed = 5;
  s.model.thermostat = false;
  s.model.add_type({"water", false, {0, 0, 0}});
  s.model.set_pair(0, 0, {-40, 25, 0});
  s.box.hi = {5.5, 5.5, 5.5};
  std::int64_t next = 0;
  ms::fill_random(s.particles, 0, {0, 0, 0}, s.box.hi, 1100, 5, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 5);
  return s;
}

class Reorder : public OnEveryBackend {};

// After 0 to 9 steps since the last sort, the forces equal those computed from scratch (a sort
// and a fresh cell list) on the same positions, to round-off.
TEST_P(Reorder, StaleCellsMissNoPair) {
  Box s = liquid();
  ms::SimulationOptions o = options();
  o.reorder_every = 10;
  o.skin = 0.4;
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.005, o);
  sim->run(200);  // relax the random start (no thermostat: energy is conserved)
  for (int k = 0; k < 10; ++k) {
    sim->run(1);
    const ms::ParticleSet p = sim->particles();
    auto fresh = ms::make_simulation(s.model, s.box, p, 0.005, options());
    const auto a = sim->forces(), b = fresh->forces();
    double diff = 0, scale = 0;
    for (int c = 0; c < 3; ++c)
      for (size_t i = 0; i < p.size(); ++i) {
        diff = std::max(diff, std::abs(a[c][i] - b[c][i]));
        scale = std::max(scale, std::abs(b[c][i]));
      }
    EXPECT_LT(diff, 1e-10 * scale) << "step " << sim->step();
  }
}

TEST_P(Reorder, RefusesAnIntervalWithoutSkin) {
  Box s = liquid();
  ms::SimulationOptions o = options();
  o.reorder_every = 4;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.005, o), mesorock::ConfigError);
  o.skin = 2;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.005, o), mesorock::ConfigError);
}

MESOROCK_ON_EVERY_BACKEND(Reorder);

}  // namespace
