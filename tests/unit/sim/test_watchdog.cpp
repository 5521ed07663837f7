// The numerical watchdog (sim/watchdog.h): a run that blows up stops with a NumericalError whose
// one-line message names the first failing step, the particle (the smallest id when several fail
// at once) and the quantity. One body for every backend; on the GPU the host reads the device's
// record only every poll_steps steps, yet reports the same first step and particle.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <regex>
#include <string>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

// 320 DPD particles (a = 25, gamma = 4.5) at rho = 5 in a periodic 4^3 box.
struct Bulk {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

Bulk bulk(ms::Precision precision = ms::Precision::Double) {
  Bulk s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.precision = precision;
  s.model.seed = 5;
  const int t = s.model.add_type({"fluid", false, {0, 0, 0}});
  s.model.set_pair(t, t, {25, 0, 4.5});
  s.box.hi = {4, 4, 4};
  std::int64_t next = 0;
  ms::fill_random(s.particles, t, {0, 0, 0}, {4, 4, 4}, 320, 5, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 5);
  return s;
}

std::string error_of(ms::Simulation& sim, std::uint64_t steps) {
  try {
    sim.run(steps);
  } catch (const mesorock::NumericalError& e) {
    return e.what();
  }
  return "";
}

class Watchdog : public OnEveryBackend {};

TEST_P(Watchdog, RunawayParticleStopsTheRunAtStepOneNamingIt) {
  Bulk s = bulk();
  s.particles.vx[7] = 500;  // 5 rc per step at dt = 0.01; the limit is 1 rc per step (100)
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  const std::string msg = error_of(*sim, 20);
  EXPECT_TRUE(std::regex_match(
      msg, std::regex("step 1: particle 7: velocity [3-5][0-9][0-9] exceeds the "
                      "runaway limit 100 \\(1 rc per step at dt = "
                      "0\\.01\\) at \\([-0-9.e+, ]+\\); dt may be too large for these forces")))
      << msg;
}

TEST_P(Watchdog, SeveralRunawaysReportTheSmallestIdOnEveryBackend) {
  Bulk s = bulk();
  for (int i : {250, 31, 99}) s.particles.vz[static_cast<size_t>(i)] = -300;
  ms::SimulationOptions o = options();
  o.watchdog.poll_steps = 7;  // the GPU host learns of it at a later poll, yet names step 1
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
  const std::string msg = error_of(*sim, 50);
  EXPECT_TRUE(
      std::regex_match(msg, std::regex("step 1: particle 31: velocity [1-3][0-9][0-9] exceeds .*")))
      << msg;
}

TEST_P(Watchdog, NonFiniteForceIsNamedAsTheForce) {
  Bulk s = bulk();
  s.model.types[0].body_force = {0, std::numeric_limits<double>::infinity(), 0};
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  const std::string msg = error_of(*sim, 5);
  // The infinite force has made velocities infinite and the dissipative forces NaN by step 1.
  EXPECT_TRUE(
      std::regex_match(msg, std::regex("step 1: particle 0: force is not finite \\(\\|f\\| = "
                                       "-?(inf|nan)\\); dt = 0\\.01 may be too large for "
                                       "these forces")))
      << msg;
}

TEST_P(Watchdog, SinglePrecisionOverflowIsARunawayWithItsValue) {
  Bulk s = bulk(ms::Precision::Single);
  s.model.types[0].body_force = {1e30, 0, 0};  // finite in float; v = dt g = 1e28 squares to inf
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  const std::string msg = error_of(*sim, 5);
  EXPECT_EQ(msg.rfind("step 1: particle 0: velocity 1e+28 exceeds the runaway limit 100", 0), 0u)
      << msg;
}

TEST_P(Watchdog, LimitFollowsDtAndTheOptionAndOffLetsTheRunContinue) {
  Bulk s = bulk();
  s.particles.vx[3] = 500;
  {
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.001, options());
    EXPECT_EQ(error_of(*sim, 10), "");  // 0.5 rc per step at dt = 0.001
  }
  {
    ms::SimulationOptions o = options();
    o.watchdog.runaway_displacement = 6;  // 600 at dt = 0.01
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    EXPECT_EQ(error_of(*sim, 10), "");
  }
  {
    ms::SimulationOptions o = options();
    o.watchdog.enabled = false;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    EXPECT_EQ(error_of(*sim, 10), "");
    EXPECT_EQ(sim->step(), 10u);
  }
}

TEST_P(Watchdog, BadOptionsAreConfigErrors) {
  Bulk s = bulk();
  ms::SimulationOptions o = options();
  o.watchdog.runaway_displacement = 0;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, o), mesorock::ConfigError);
  o = options();
  o.watchdog.poll_steps = 0;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, o), mesorock::ConfigError);
}

// A rank or box without particles (the MPI decomposition will produce empty ranks) still steps.
TEST_P(Watchdog, EmptySystemRunsAndReportsNothing) {
  Bulk s = bulk();
  s.particles = ms::ParticleSet{};
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  EXPECT_EQ(error_of(*sim, 20), "");
  EXPECT_EQ(sim->step(), 20u);
  EXPECT_EQ(sim->kinetic_temperature(), 0.0);
  EXPECT_EQ(sim->particles().size(), 0u);
}

MESOROCK_ON_EVERY_BACKEND(Watchdog);

}  // namespace
