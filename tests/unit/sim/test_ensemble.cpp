// Ensembles (sim/ensemble.h): members stepped side by side on threads of their own compute every
// bit that each computes alone. One body for every backend: on the GPU the members' work overlaps
// on per-thread streams and runs through CUDA graphs.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <stdexcept>
#include <vector>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/ensemble.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

// Member k: an mDPD liquid with the thermostat (so the seed matters) beside a frozen wall, its
// own seed and start.
struct Member {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

Member member(int k) {
  Member m;
  m.model.seed = 1000 + static_cast<std::uint64_t>(k);
  const int fluid = m.model.add_type({"fluid", false, {0.05, 0, 0}});
  const int wall = m.model.add_type({"wall", true, {0, 0, 0}});
  m.model.set_pair(fluid, fluid, {-40, 25, 4.5});
  m.model.set_pair(fluid, wall, {-30, 25, 4.5});
  m.model.set_pair(wall, wall, {-40, 25, 4.5});
  m.box.hi = {6, 6, 7};
  m.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_random(m.particles, fluid, {0, 0, 1}, {6, 6, 7}, 1500, 20 + k, next);
  ms::fill_lattice(m.particles, wall, {0, 0, 0}, {6, 6, 1}, 8, next);
  ms::assign_maxwell_velocities(m.particles, m.model, 1.0, 20 + k);
  return m;
}

class Ensemble : public OnEveryBackend {};

// 60 steps, in runs of 37 and 23 (graphs replay runs of up to 16 steps; an odd last step steps
// alone).
ms::ParticleSet run_member(int k, const ms::SimulationOptions& o) {
  const Member m = member(k);
  auto sim = ms::make_simulation(m.model, m.box, m.particles, 0.01, o);
  sim->run(37);
  sim->run(23);
  return sim->particles();
}

TEST_P(Ensemble, MembersComputeEveryBitTheyComputeAlone) {
  constexpr int kMembers = 4;
  ms::SimulationOptions o = options();
  o.threads = 1;
  std::vector<ms::ParticleSet> alone;
  for (int k = 0; k < kMembers; ++k) alone.push_back(run_member(k, o));
  std::vector<ms::ParticleSet> together(kMembers);
  ms::run_ensemble(kMembers, [&](int k) { together[k] = run_member(k, o); });
  for (int k = 0; k < kMembers; ++k) {
    const ms::ParticleSet &a = alone[k], &b = together[k];
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a.id[i], b.id[i]) << "member " << k;
      ASSERT_EQ(a.x[i], b.x[i]) << "member " << k << ", particle " << i;
      ASSERT_EQ(a.y[i], b.y[i]) << "member " << k << ", particle " << i;
      ASSERT_EQ(a.z[i], b.z[i]) << "member " << k << ", particle " << i;
      ASSERT_EQ(a.vx[i], b.vx[i]) << "member " << k << ", particle " << i;
    }
  }
  // The members differ from each other (their seeds and starts): the comparison above is not
  // between copies of one run.
  EXPECT_NE(alone[0].x[0], alone[1].x[0]);
}

MESOROCK_ON_EVERY_BACKEND(Ensemble);

TEST(RunEnsemble, RunsEveryMemberOnceAndRethrowsTheLowestFailure) {
  std::atomic<int> ran{0};
  std::vector<int> count(10, 0);
  try {
    ms::run_ensemble(
        10,
        [&](int k) {
          ++count[static_cast<size_t>(k)];
          ++ran;
          if (k == 7 || k == 3) throw std::runtime_error("member " + std::to_string(k));
        },
        3);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "member 3");
  }
  EXPECT_EQ(ran.load(), 10);  // a failure stops no other member
  for (int c : count) EXPECT_EQ(c, 1);
}

TEST(RunEnsemble, RefusesANegativeCountAndRunsNothingForZero) {
  EXPECT_THROW(ms::run_ensemble(-1, [](int) {}), mesorock::ConfigError);
  int ran = 0;
  ms::run_ensemble(0, [&](int) { ++ran; });
  EXPECT_EQ(ran, 0);
}

}  // namespace

namespace {

TEST(RunEnsemble, ManySmallSystemsTakeOneLaneEach) {
  EXPECT_EQ(ms::ensemble_lanes(64, 20000, 0), 2);  // 1.28 M particles together
  EXPECT_EQ(ms::ensemble_lanes(8, 300000, 0), 1);  // members big enough alone
  EXPECT_EQ(ms::ensemble_lanes(4, 20000, 0), 0);   // too few: each system chooses
  EXPECT_EQ(ms::ensemble_lanes(1, 1e6, 0), 0);     // one system chooses for itself
  EXPECT_EQ(ms::ensemble_lanes(64, 20000, 4), 4);  // asked for
}

}  // namespace

namespace {

// lanes_per_particle is checked for every backend, before anything is built.
TEST(RunEnsemble, LanesPerParticleOtherThan0124Or8IsRefused) {
  const Member m = member(0);
  ms::SimulationOptions o;
  o.lanes_per_particle = 3;
  EXPECT_THROW(ms::make_simulation(m.model, m.box, m.particles, 0.01, o), mesorock::ConfigError);
  o.lanes_per_particle = 4;  // the CPU has no lanes: accepted and ignored
  EXPECT_NO_THROW(ms::make_simulation(m.model, m.box, m.particles, 0.01, o));
}

}  // namespace
