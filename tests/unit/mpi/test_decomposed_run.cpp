// The decomposed solver (sim/domain) under mpirun -np 2 and -np 4, against the single-rank solver
// run on every rank on the same particles: the same forces (to round-off: the sums run in another
// order), the same short trajectories, particle counts and ids conserved exactly, momentum
// conserved, averages equal within their errors, and a balanced split of an uneven system.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <set>
#include <string>

#include "mesorock/errors.h"
#include "mpi_world.h"
#include "sim/checkpoint.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::g_world;

namespace {

struct System {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// The A = -40 mDPD liquid at rho = 6.5 in a periodic box, double precision.
System liquid(double Lx, double Ly, double Lz, std::uint64_t seed) {
  System s;
  s.model.seed = seed;
  s.model.add_type({"water", false, {0, 0, 0}});
  s.model.set_pair(0, 0, {-40, 25, 4.5});
  s.box.hi = {Lx, Ly, Lz};
  std::int64_t next = 0;
  ms::fill_random(s.particles, 0, {0, 0, 0}, s.box.hi,
                  static_cast<std::int64_t>(6.5 * Lx * Ly * Lz), seed, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}

// A channel: frozen lattice walls (density 8) at both z faces with the wall model, a body force
// along x, reflective z faces; a pushing slab type along z would be overkill here.
System channel(std::uint64_t seed) {
  System s;
  s.model.seed = seed;
  s.model.add_type({"fluid", false, {0.05, 0, 0}});
  s.model.add_type({"wall", true, {0, 0, 0}});
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) s.model.set_pair(a, b, {-40, 25, 4.5});
  s.model.wall_model.enabled = true;
  s.box.hi = {8, 6, 8};
  s.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_lattice(s.particles, 1, {0, 0, 0}, {8, 6, 1.5}, 8, next);
  ms::fill_lattice(s.particles, 1, {0, 0, 6.5}, {8, 6, 8}, 8, next);
  ms::fill_random(s.particles, 0, {0, 0, 1.6}, {8, 6, 6.4}, 6 * 48 * 5, seed, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}

// MESOROCK_TEST_BACKEND=cuda runs both sides of every comparison on the GPU (the GPU machine:
// several ranks may share one device).
ms::BackendKind test_backend() {
  const char* b = std::getenv("MESOROCK_TEST_BACKEND");
  return b && std::string(b) == "cuda" ? ms::BackendKind::CUDA : ms::BackendKind::CPU;
}

ms::SimulationOptions decomposed(ms::DecompositionMethod m = ms::DecompositionMethod::RCB,
                                 std::uint32_t axes = 7) {
  ms::SimulationOptions o;
  o.backend = test_backend();
  o.threads = 1;
  o.comm = g_world;
  o.decomposition.method = m;
  o.decomposition.axes = axes;
  return o;
}

ms::SimulationOptions single() {
  ms::SimulationOptions o;
  o.backend = test_backend();
  o.threads = 1;
  return o;
}

double max_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

void expect_same_forces(const System& s, const ms::SimulationOptions& o, double tolerance) {
  auto ref = ms::make_simulation(s.model, s.box, s.particles, 0.01, single());
  auto dd = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
  ASSERT_EQ(dd->ranks(), g_world->size());
  const auto fa = ref->forces(), fb = dd->forces();
  double scale = 0;
  for (int a = 0; a < 3; ++a)
    for (double f : fa[static_cast<size_t>(a)]) scale = std::max(scale, std::abs(f));
  for (int a = 0; a < 3; ++a)
    EXPECT_LE(max_difference(fa[static_cast<size_t>(a)], fb[static_cast<size_t>(a)]),
              tolerance * scale)
        << "axis " << a << " (" << dd->decomposition_report() << ")";
  EXPECT_LE(max_difference(ref->densities(), dd->densities()), 1e-12);
}

// The solid grid on several ranks: a liquid driven along x through a slab of solid voxels with no
// wall particles in it. Without the bounce the fluid flows into the slab and the decomposed leak
// invariant (summed over the ranks, the deepest particle found on its rank) counts exactly what
// the gathered particles and the mask say; with the bounce no rank lets one in.
TEST(Decomposed, SolidGridBouncesAndCountsOnEveryRank) {
  for (const bool bounce : {false, true}) {
    System s = liquid(8, 6, 6, 31);
    s.model.types[0].body_force = {0.5, 0, 0};
    auto mask = std::make_shared<ms::SolidMask>();
    mask->dims = {16, 12, 12};
    mask->voxel = {0.5, 0.5, 0.5};
    mask->solid.assign(16 * 12 * 12, 0);
    for (int k = 0; k < 12; ++k)
      for (int j = 0; j < 12; ++j)
        for (int i = 6; i < 8; ++i) mask->solid[mask->index(i, j, k)] = 1;  // x in [3, 4)
    ms::ParticleSet outside;
    for (size_t i = 0; i < s.particles.size(); ++i)
      if (!(s.particles.x[i] >= 3 && s.particles.x[i] < 4))
        outside.add(s.particles.x[i], s.particles.y[i], s.particles.z[i], s.particles.vx[i],
                    s.particles.vy[i], s.particles.vz[i], 0, s.particles.id[i]);
    s.particles = outside;
    s.model.solid.mask = mask;
    s.model.solid.bounce = bounce;
    s.model.solid.stop_depth = 4;
    auto dd = ms::make_simulation(s.model, s.box, s.particles, 0.01, decomposed());
    dd->run(200);
    const ms::SolidIntrusion in = dd->solid_intrusion();
    const ms::ParticleSet p = dd->particles();
    std::uint64_t inside = 0;
    for (size_t i = 0; i < p.size(); ++i) inside += p.x[i] >= 3 && p.x[i] < 4;
    ASSERT_TRUE(in.available);
    EXPECT_EQ(in.inside, inside) << "bounce " << bounce;
    if (bounce) {
      EXPECT_EQ(in.inside, 0u);
    } else {
      EXPECT_GT(in.inside, 10u);
      ASSERT_GE(in.deepest_id, 0);
      EXPECT_GT(in.max_depth, 0.0);
      EXPECT_LE(in.max_depth, 0.5);  // the slab is 1 rc thick
      EXPECT_GE(in.deepest_position[0], 3.0);
      EXPECT_LT(in.deepest_position[0], 4.0);
    }
  }
}

TEST(Decomposed, ForcesEqualTheSingleRankOnes) {
  MESOROCK_REQUIRE_RANKS();
  // Round-off only: each force is the same set of pair terms summed in another order.
  expect_same_forces(liquid(6, 6, 6, 3), decomposed(), 1e-12);
  expect_same_forces(liquid(9, 4, 4, 4), decomposed(ms::DecompositionMethod::Slabs, 1), 1e-12);
  expect_same_forces(channel(5), decomposed(), 1e-12);
}

TEST(Decomposed, ShortTrajectoriesFollowTheSingleRankOne) {
  MESOROCK_REQUIRE_RANKS();
  for (const System& s : {liquid(6, 6, 6, 7), channel(8)}) {
    auto ref = ms::make_simulation(s.model, s.box, s.particles, 0.01, single());
    auto dd = ms::make_simulation(s.model, s.box, s.particles, 0.01, decomposed());
    ref->run(20);
    dd->run(20);
    const ms::ParticleSet a = ref->particles(), b = dd->particles();
    ASSERT_EQ(a.size(), b.size());
    // Separations of a few 1e-13 grow by a factor of a few per step in a dense liquid; 20 steps
    // stay far below 1e-6.
    EXPECT_LT(max_difference(a.x, b.x), 1e-6);
    EXPECT_LT(max_difference(a.vz, b.vz), 1e-5);
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(ref->wall_corrections(), dd->wall_corrections());
  }
}

TEST(Decomposed, ConservesParticlesIdsAndMomentum) {
  MESOROCK_REQUIRE_RANKS();
  System s = liquid(8, 6, 5, 11);
  auto dd = ms::make_simulation(s.model, s.box, s.particles, 0.01, decomposed());
  const auto p0 = dd->momentum();
  dd->run(400);
  const ms::ParticleSet p = dd->particles();
  ASSERT_EQ(p.size(), s.particles.size());
  const std::set<std::int64_t> ids(p.id.begin(), p.id.end());
  EXPECT_EQ(ids.size(), p.size());
  EXPECT_EQ(*ids.begin(), 0);
  EXPECT_EQ(*ids.rbegin(), static_cast<std::int64_t>(p.size()) - 1);
  const auto p1 = dd->momentum();
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(p1[static_cast<size_t>(a)], p0[static_cast<size_t>(a)], 1e-9 * p.size());
  // Every particle inside the box (periodic wrap across ranks works).
  for (size_t i = 0; i < p.size(); ++i) {
    ASSERT_GE(p.x[i], 0.0);
    ASSERT_LT(p.x[i], 8.0);
  }
}

// Temperature and pressure of the decomposed run agree with the single-rank run within their
// statistical errors (different round-off makes them different trajectories).
TEST(Decomposed, AveragesAgreeWithTheSingleRankRun) {
  MESOROCK_REQUIRE_RANKS();
  System s = liquid(5, 5, 5, 13);
  auto measure = [&](const ms::SimulationOptions& o, double& T, double& p, double& Terr,
                     double& perr) {
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    sim->run(200);
    std::vector<double> ts, ps;
    for (int k = 0; k < 80; ++k) {
      sim->run(10);
      ts.push_back(sim->kinetic_temperature());
      ps.push_back(sim->stress().pressure_conservative());
    }
    auto stats = [](const std::vector<double>& v, double& mean, double& err) {
      // 8 blocks of 10 samples.
      std::vector<double> blocks;
      for (size_t b = 0; b < 8; ++b)
        blocks.push_back(std::accumulate(v.begin() + b * 10, v.begin() + b * 10 + 10, 0.0) / 10);
      mean = std::accumulate(blocks.begin(), blocks.end(), 0.0) / 8;
      double var = 0;
      for (double x : blocks) var += (x - mean) * (x - mean);
      err = std::sqrt(var / 7 / 8);
    };
    stats(ts, T, Terr);
    stats(ps, p, perr);
  };
  double T1, p1, eT1, ep1, T2, p2, eT2, ep2;
  measure(single(), T1, p1, eT1, ep1);
  measure(decomposed(), T2, p2, eT2, ep2);
  EXPECT_LT(std::abs(T1 - T2), 4 * std::hypot(eT1, eT2) + 1e-3) << T1 << " vs " << T2;
  EXPECT_LT(std::abs(p1 - p2), 4 * std::hypot(ep1, ep2) + 0.05) << p1 << " vs " << p2;
  // Warren's fit at rho = 6.5: p = 22.5 (eos-mdpd validates it).
  EXPECT_NEAR(p2, 22.5, 2.0);
}

// allgatherv in rounds (MPI counts are int: gathers above 2 GiB in all need them), run here on
// small data with rounds of a few bytes: every rank's bytes arrive whole and in rank order, the
// ranks sending different amounts (rank r sends 37 r + 5 bytes; one rank may send nothing).
TEST(Communicator, AllgatherInRoundsKeepsEveryRanksBytesInOrder) {
  MESOROCK_REQUIRE_RANKS();
  for (const std::size_t round : {std::size_t{1} << 30, std::size_t{16}, std::size_t{3}}) {
    g_world->set_gather_round_bytes(round);
    const int me = g_world->rank();
    std::vector<char> mine(static_cast<size_t>(me == 1 ? 0 : 37 * me + 5));
    for (size_t k = 0; k < mine.size(); ++k) mine[k] = static_cast<char>(me * 7 + k);
    std::vector<char> all;
    std::vector<std::size_t> per_rank;
    g_world->allgatherv(mine, all, per_rank);
    ASSERT_EQ(per_rank.size(), static_cast<size_t>(g_world->size()));
    std::vector<char> expected;
    for (int r = 0; r < g_world->size(); ++r) {
      const size_t n = static_cast<size_t>(r == 1 ? 0 : 37 * r + 5);
      EXPECT_EQ(per_rank[static_cast<size_t>(r)], n) << "round " << round;
      for (size_t k = 0; k < n; ++k) expected.push_back(static_cast<char>(r * 7 + k));
    }
    EXPECT_EQ(all, expected) << "round " << round;
  }
  g_world->set_gather_round_bytes(std::size_t{1} << 30);
}

// A decomposed run's state is every rank's particles gathered in the original order; written to a
// checkpoint file and read back it resumes on these ranks or on one, and a single-rank state
// resumes decomposed. Right after the resume the forces are the saved ones, bit for bit (they must
// move with their particles when the storage is sorted); ten steps later the particles follow the
// uninterrupted run to round-off growth (the order of the force sums differs).
TEST(Decomposed, CheckpointsResumeOnAnyNumberOfRanks) {
  MESOROCK_REQUIRE_RANKS();
  const System s = channel(21);  // wall model (phi), thermostat (v~), body force
  auto expect_follows = [](ms::Simulation& resumed, const ms::SimulationState& saved,
                           const ms::ParticleSet& after, const char* what) {
    const auto f = resumed.forces();
    EXPECT_EQ(f[0], saved.fx) << what;
    EXPECT_EQ(f[2], saved.fz) << what;
    EXPECT_EQ(resumed.step(), saved.step) << what;
    resumed.run(10);
    const ms::ParticleSet p = resumed.particles();
    ASSERT_EQ(p.size(), after.size()) << what;
    EXPECT_EQ(p.id, after.id) << what;
    EXPECT_EQ(p.type, after.type) << what;
    EXPECT_LT(max_difference(p.x, after.x), 1e-8) << what;
    EXPECT_LT(max_difference(p.vz, after.vz), 1e-7) << what;
  };

  auto dd = ms::make_simulation(s.model, s.box, s.particles, 0.01, decomposed());
  dd->run(30);
  const ms::SimulationState gathered = dd->state().in_original_order();
  ASSERT_EQ(gathered.size(), s.particles.size());
  EXPECT_EQ(gathered.step, 30u);
  EXPECT_FALSE(gathered.bvf.empty());
  EXPECT_FALSE(gathered.vex.empty());
  dd->run(10);
  const ms::ParticleSet after = dd->particles();

  // Through a file: rank 0 writes it, every rank reads it.
  const std::string file = "decomposed_checkpoint_" + std::to_string(g_world->size()) + ".h5";
  if (g_world->rank() == 0) {
    ms::CheckpointFile c;
    c.state = gathered;
    c.created_by = "unit_mpi";
    ms::write_checkpoint(file, c);
  }
  g_world->barrier();
  const ms::SimulationState read = ms::read_checkpoint(file).state;
  g_world->barrier();
  if (g_world->rank() == 0) std::remove(file.c_str());

  auto on_ranks = ms::resume_simulation(s.model, s.box, read, decomposed());
  expect_follows(*on_ranks, gathered, after, "resumed on the same ranks");
  auto on_one = ms::resume_simulation(s.model, s.box, read, single());
  expect_follows(*on_one, gathered, after, "resumed on one rank");

  auto one = ms::make_simulation(s.model, s.box, s.particles, 0.01, single());
  one->run(30);
  const ms::SimulationState sorted = one->state();  // storage order, not the original one
  one->run(10);
  auto spread = ms::resume_simulation(s.model, s.box, sorted, decomposed());
  expect_follows(*spread, sorted.in_original_order(), one->particles(),
                 "a single-rank state resumed decomposed");

  // A state that does not fit the model is refused on every rank alike (no rank left waiting).
  ms::Model no_walls = s.model;
  no_walls.wall_model.enabled = false;
  EXPECT_THROW(ms::resume_simulation(no_walls, s.box, read, decomposed()), mesorock::ConfigError);
}

// Half the box is empty: equal slabs give the ranks on the empty side nothing to do; RCB on the
// measured cost splits the work evenly.
TEST(Decomposed, RcbBalancesAnUnevenSystem) {
  MESOROCK_REQUIRE_RANKS();
  System s;
  s.model.seed = 17;
  s.model.add_type({"water", false, {0, 0, 0}});
  s.model.set_pair(0, 0, {-40, 25, 4.5});
  s.box.hi = {16, 5, 5};
  s.box.periodic = {false, true, true};
  std::int64_t next = 0;
  ms::fill_random(s.particles, 0, {0, 0, 0}, {6, 5, 5}, 6 * 25 * 7, 17, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 17);
  auto imbalance = [](const std::vector<double>& c) {
    const double mean = std::accumulate(c.begin(), c.end(), 0.0) / static_cast<double>(c.size());
    return *std::max_element(c.begin(), c.end()) / mean;
  };
  auto slabs = ms::make_simulation(s.model, s.box, s.particles, 0.01,
                                   decomposed(ms::DecompositionMethod::Slabs, 1));
  auto o = decomposed(ms::DecompositionMethod::RCB, 1);
  o.decomposition.rebalance_every = 50;
  auto rcb = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
  slabs->run(100);
  rcb->run(100);
  const double equal = imbalance(slabs->rank_costs()), balanced = imbalance(rcb->rank_costs());
  if (g_world->rank() == 0)
    std::printf("imbalance (max/mean cost) on %d ranks: equal slabs %.3f, RCB %.3f\n",
                g_world->size(), equal, balanced);
  EXPECT_GT(equal, 1.5) << slabs->decomposition_report();
  EXPECT_LT(balanced, 1.10) << rcb->decomposition_report();
}

}  // namespace
