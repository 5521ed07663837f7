// Injection and ejection boundaries (sim/injection.h) and the stress of a region
// (Simulation::region_stress). One body for every backend.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct Channel {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// Standard DPD fluid (a = 25, rho = 3) in a 12 x 4 x 4 box, reflective in x, all "source" at the
// start; "working" is injected in x < 2 and particles are taken from x >= 10.
Channel channel(std::uint64_t every) {
  Channel s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.seed = 33;
  const int source = s.model.add_type({"source", false, {0, 0, 0}});
  const int working = s.model.add_type({"working", false, {0, 0, 0}});
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) s.model.set_pair(a, b, {25, 0, 4.5});
  ms::InjectionSpec q;
  q.inject_type = working;
  q.eject_types = (1u << source) | (1u << working);
  q.inlet_lo = {0, 0, 0};
  q.inlet_hi = {2, 4, 4};
  q.outlet_lo = {10, 0, 0};
  q.outlet_hi = {12, 4, 4};
  q.every = every;
  s.model.injections.push_back(q);
  s.box.hi = {12, 4, 4};
  s.box.periodic = {false, true, true};
  std::int64_t next = 0;
  ms::fill_random(s.particles, source, {0, 0, 0}, {12, 4, 4}, 576, 33, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 33);
  return s;
}

int count_type(const ms::ParticleSet& p, int type) {
  return static_cast<int>(std::count(p.type.begin(), p.type.end(), type));
}

class Injection : public OnEveryBackend {};

TEST_P(Injection, MovesOneParticlePerEventFromTheOutletToTheInlet) {
  Channel s = channel(5);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  // One event at step 5: the particle it moved stands in the inlet box as the injected type.
  sim->run(5);
  ms::ParticleSet p = sim->particles();
  ASSERT_EQ(count_type(p, 1), 1);
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == 1) {
      EXPECT_GE(p.x[i], 0.0);
      EXPECT_LT(p.x[i], 2.0);
      EXPECT_LE(p.y[i], 4.0);
      EXPECT_LE(p.z[i], 4.0);
      // It left from the outlet box: its initial position (same id, same index) was there.
      EXPECT_GE(s.particles.x[i], 10.0 - 0.3) << "picked away from the outlet";
    }
  // 500 steps: 100 events, each moving one particle (the outlet is never empty of fluid).
  sim->run(495);
  p = sim->particles();
  const auto counts = sim->injections();
  ASSERT_EQ(counts.size(), 1u);
  EXPECT_EQ(counts[0].injected + counts[0].missed, 100u);
  EXPECT_EQ(counts[0].missed, 0u);
  // Injected particles may have been ejected again (they are ejectable too): at most 100 working.
  EXPECT_LE(count_type(p, 1), 100);
  EXPECT_GE(count_type(p, 1), 80);
  EXPECT_EQ(p.size(), s.particles.size());
  const std::set<std::int64_t> ids(p.id.begin(), p.id.end());
  EXPECT_EQ(ids.size(), p.size()) << "ids stay unique";
  const double T = sim->kinetic_temperature();
  EXPECT_NEAR(T, 1.0, 0.1) << "injected particles enter at kBT";
}

TEST_P(Injection, PicksTheSameParticleOnEveryBackendAndThreadCount) {
  Channel s = channel(1);
  ms::SimulationOptions cpu1;
  cpu1.threads = 1;
  auto ref = ms::make_simulation(s.model, s.box, s.particles, 0.01, cpu1);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  // Three events: each picks by key, so the same ids move wherever they run.
  ref->run(3);
  sim->run(3);
  const ms::ParticleSet a = ref->particles(), b = sim->particles();
  std::vector<std::int64_t> moved_a, moved_b;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a.type[i] == 1) moved_a.push_back(a.id[i]);
    if (b.type[i] == 1) moved_b.push_back(b.id[i]);
  }
  ASSERT_EQ(moved_a.size(), 3u);
  EXPECT_EQ(moved_a, moved_b);
  for (size_t i = 0; i < a.size(); ++i)
    if (a.type[i] == 1) {
      EXPECT_NEAR(a.x[i], b.x[i], 1e-4);
      EXPECT_NEAR(a.vx[i], b.vx[i], 1e-3);
    }
}

TEST_P(Injection, CountsEventsWithoutACandidate) {
  Channel s = channel(10);
  s.model.injections[0].eject_types = 1u << 1;  // only "working", of which there is none
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  sim->run(100);
  const auto counts = sim->injections();
  EXPECT_EQ(counts[0].injected, 0u);
  EXPECT_EQ(counts[0].missed, 10u);
  EXPECT_EQ(count_type(sim->particles(), 1), 0);
}

TEST_P(Injection, RefusesBadBoundaries) {
  auto refused = [&](auto change) {
    Channel s = channel(5);
    change(s.model.injections[0], s.model);
    EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
                 mesorock::ConfigError);
  };
  refused([](ms::InjectionSpec& q, ms::Model&) { q.outlet_lo = {1, 0, 0}; });  // overlaps inlet
  refused([](ms::InjectionSpec& q, ms::Model&) { q.inlet_hi = {2, 4, 5}; });   // outside the box
  refused([](ms::InjectionSpec& q, ms::Model&) { q.every = 0; });
  refused([](ms::InjectionSpec& q, ms::Model&) { q.eject_types = 0; });
  refused([](ms::InjectionSpec& q, ms::Model&) { q.per_event = 0; });
  refused([](ms::InjectionSpec& q, ms::Model& m) {
    m.types[static_cast<size_t>(q.inject_type)].frozen = true;
  });
  refused([](ms::InjectionSpec& q, ms::Model&) { q.inject_type = 7; });
  refused([](ms::InjectionSpec& q, ms::Model&) { q.stop_step = q.start_step; });
}

// The stress of a region that covers the whole box is the box's stress; a region inside a
// homogeneous fluid has, on average, the bulk pressure.
TEST_P(Injection, RegionStressAgreesWithTheBoxStress) {
  Channel s = channel(5);
  s.model.injections.clear();
  s.box.periodic = {true, true, true};
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  sim->run(300);
  ms::RegionSelection all;
  all.lo = s.box.lo;
  all.hi = s.box.hi;
  const ms::StressSample whole = sim->stress(), region = sim->region_stress(all);
  EXPECT_NEAR(region.pressure(), whole.pressure(), 1e-9 * std::abs(whole.pressure()));
  double inner = 0, bulk = 0;
  const int samples = 40;
  ms::RegionSelection half;
  half.lo = {3, 0, 0};
  half.hi = {9, 4, 4};
  for (int k = 0; k < samples; ++k) {
    sim->run(10);
    inner += sim->region_stress(half).pressure();
    bulk += sim->stress().pressure();
  }
  inner /= samples;
  bulk /= samples;
  // Groot & Warren: p(rho = 3) = 23.65 for a = 25. The half box fluctuates more than the whole;
  // 40 samples bring its mean within a few percent.
  EXPECT_NEAR(bulk, 23.65, 0.7);
  EXPECT_NEAR(inner, bulk, 0.05 * bulk);
  ms::RegionSelection none = half;
  none.type_mask = 1u << 1;  // no "working" particles exist
  EXPECT_EQ(sim->region_stress(none).pressure(), 0.0);
}

MESOROCK_ON_EVERY_BACKEND(Injection);

}  // namespace
