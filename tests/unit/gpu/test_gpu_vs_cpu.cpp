// The CUDA backend against the CPU backend on the same configuration (label "gpu"; skipped
// without a CUDA build or device). Same precision on both sides.
#include <gtest/gtest.h>

#include <cassert>
#include <cmath>

#include "mesorock/errors.h"
#include "sim/domain/communicator.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;

namespace {

struct Case {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

constexpr int kFluid = 0, kWall = 1;

// The model of these cases: a fluid (type kFluid, driven along x) and a frozen wall (kWall), no
// particles yet.
Case fluid_and_wall(ms::Precision precision, std::uint64_t seed,
                    ms::ConservativeKind kind = ms::ConservativeKind::MDPD,
                    ms::DensityKernelKind kernel = ms::DensityKernelKind::Warren) {
  Case c;
  c.model.conservative = kind;
  c.model.density_kernel = kernel;
  c.model.precision = precision;
  c.model.seed = seed;
  const int fluid = c.model.add_type({"fluid", false, {0.02, 0, 0}});
  const int wall = c.model.add_type({"wall", true, {0, 0, 0}});
  assert(fluid == kFluid && wall == kWall);
  const double B = kind == ms::ConservativeKind::MDPD ? 25 : 0;
  const double A = kind == ms::ConservativeKind::MDPD ? -40 : 25;
  c.model.set_pair(fluid, fluid, {A, B, 4.5});
  c.model.set_pair(fluid, wall, {A * 0.8, B, 4.5});
  c.model.set_pair(wall, wall, {A, B, 4.5});
  return c;
}

// A box lx x ly x lz, periodic in x and y, with a frozen wall lattice (density 8) in z below
// `wall` and `fluid` particles at random above it; positions and velocities from `seed`.
void fill_over_wall(Case& c, double lx, double ly, double lz, double wall, std::int64_t fluid,
                    std::uint64_t seed) {
  c.box.hi = {lx, ly, lz};
  c.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_random(c.particles, kFluid, {0, 0, wall}, {lx, ly, lz}, fluid, seed, next);
  ms::fill_lattice(c.particles, kWall, {0, 0, 0}, {lx, ly, wall}, 8, next);
  ms::assign_maxwell_velocities(c.particles, c.model, 1.0, seed);
}

// A fluid with a frozen wall slab, body force and thermostat: every pass variant's pieces.
Case mixed_case(ms::Precision precision, ms::ConservativeKind kind, ms::DensityKernelKind kernel) {
  Case c = fluid_and_wall(precision, 77, kind, kernel);
  fill_over_wall(c, 12, 9, 10, 1, 6000, 3);
  return c;
}

class GpuVsCpu : public ::testing::TestWithParam<ms::Precision> {
 protected:
  void SetUp() override {
    const std::string why = ms::cuda_unavailable_reason();
    if (!why.empty()) GTEST_SKIP() << why;
  }
};

double rms(const std::array<std::vector<double>, 3>& f) {
  double s = 0;
  for (int a = 0; a < 3; ++a)
    for (double v : f[a]) s += v * v;
  return std::sqrt(s / (3.0 * f[0].size()));
}

// The largest force difference, relative to |f| plus the rms force of fa.
double worst_force_difference(const std::array<std::vector<double>, 3>& fa,
                              const std::array<std::vector<double>, 3>& fb) {
  const double scale = rms(fa);
  double worst = 0;
  for (int d = 0; d < 3; ++d)
    for (size_t i = 0; i < fa[d].size(); ++i)
      worst = std::max(worst, std::abs(fa[d][i] - fb[d][i]) / (std::abs(fa[d][i]) + scale));
  return worst;
}

// The largest position difference between two runs of the same particles.
double worst_position_difference(const ms::ParticleSet& a, const ms::ParticleSet& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i)
    worst = std::max(
        {worst, std::abs(a.x[i] - b.x[i]), std::abs(a.y[i] - b.y[i]), std::abs(a.z[i] - b.z[i])});
  return worst;
}

TEST_P(GpuVsCpu, ForcesAgreeOnTheSameConfiguration) {
  for (auto kind : {ms::ConservativeKind::DPD, ms::ConservativeKind::MDPD}) {
    for (auto kernel : {ms::DensityKernelKind::Warren, ms::DensityKernelKind::Lucy}) {
      Case c = mixed_case(GetParam(), kind, kernel);
      ms::SimulationOptions gpu;
      gpu.backend = ms::BackendKind::CUDA;
      auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01);
      auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
      EXPECT_LT(worst_force_difference(a->forces(), b->forces()), 1e-5)
          << ms::to_string(kind) << "/" << ms::to_string(kernel);
      const auto ra = a->densities(), rb = b->densities();
      for (size_t i = 0; i < ra.size(); ++i) ASSERT_NEAR(ra[i], rb[i], 1e-5 * (1 + ra[i]));
    }
  }
}

TEST_P(GpuVsCpu, TrajectoriesAgreeOverTwentySteps) {
  Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
  ms::SimulationOptions gpu;
  gpu.backend = ms::BackendKind::CUDA;
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01);
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
  a->run(20);
  b->run(20);
  const auto pa = a->particles(), pb = b->particles();
  double worst = 0;
  for (size_t i = 0; i < pa.size(); ++i) {
    ASSERT_EQ(pa.id[i], pb.id[i]);
    worst = std::max({worst, std::abs(pa.x[i] - pb.x[i]), std::abs(pa.y[i] - pb.y[i]),
                      std::abs(pa.z[i] - pb.z[i])});
  }
  EXPECT_LT(worst, 1e-4);
  const auto sa = a->stress(), sb = b->stress();
  EXPECT_NEAR(sa.pressure(), sb.pressure(), 1e-3 * std::abs(sa.pressure()));
}

// The wall model (phi, corrector, no-slip dissipation) on the same mixed case: phi and forces
// agree after construction, and trajectories over 20 steps (the fluid starts next to the wall,
// so corrections happen on both backends).
TEST_P(GpuVsCpu, WallModelAgrees) {
  Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
  c.model.wall_model.enabled = true;
  ms::SimulationOptions gpu;
  gpu.backend = ms::BackendKind::CUDA;
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01);
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
  const auto phi_a = a->boundary_volume_fractions(), phi_b = b->boundary_volume_fractions();
  ASSERT_EQ(phi_a.size(), phi_b.size());
  for (size_t i = 0; i < phi_a.size(); ++i) ASSERT_NEAR(phi_a[i], phi_b[i], 1e-5);
  EXPECT_LT(worst_force_difference(a->forces(), b->forces()), 1e-5);
  a->run(20);
  b->run(20);
  EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
  EXPECT_LT(worst_position_difference(a->particles(), b->particles()), 1e-4);
}

// The GPU corrects penetrations before the sort, finding the walls in the frozen part alone,
// then sorts the mobile part and sums once; each frozen particle adds its mobile neighbours to
// its kept sums over its frozen ones. Step by step, its rho and phi must equal those of a fresh
// GPU simulation of the same particles (which sums everything from a full sort; only the order
// within a cell differs). A missed neighbour would leave a rho off by about 0.1 (a move of dt
// |dv| ~ 0.02 rc); stale kept sums or a rho left at another particle's index, by about 1.
TEST_P(GpuVsCpu, CorrectionsBeforeTheSortKeepTheSumsExact) {
  Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
  c.model.wall_model.enabled = true;
  ms::SimulationOptions gpu;
  gpu.backend = ms::BackendKind::CUDA;
  gpu.profile = true;
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
  const double tol = GetParam() == ms::Precision::Single ? 2e-4 : 1e-10;
  std::uint64_t corrections = b->wall_corrections();  // those of the initial forces
  for (int step = 0; step < 30; ++step) {
    b->run(1);
    auto fresh = ms::make_simulation(c.model, c.box, b->particles(), 0.01, gpu);
    const auto ra = b->densities(), rb = fresh->densities();
    const auto pa = b->boundary_volume_fractions(), pb = fresh->boundary_volume_fractions();
    ASSERT_EQ(ra.size(), rb.size());
    for (size_t i = 0; i < ra.size(); ++i) {
      ASSERT_NEAR(ra[i], rb[i], tol * (1 + rb[i])) << "step " << step << ", particle " << i;
      ASSERT_NEAR(pa[i], pb[i], tol) << "step " << step << ", particle " << i;
    }
  }
  EXPECT_GT(b->wall_corrections(), corrections);  // corrections before the sort were counted
  const std::string report = b->profile_report();
  EXPECT_EQ(report.find("before the sort on 0 steps"), std::string::npos) << report;
}

// CUDA graphs replay captured runs of steps, reading the step number from device memory; every
// bit must equal the launches one by one, with and without the wall model (its corrector before
// the sort) and over runs that end mid-graph (the remainders step alone, and the next replay
// must start from the right step).
TEST_P(GpuVsCpu, GraphsChangeNoBit) {
  for (bool walls : {false, true}) {
    Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
    c.model.wall_model.enabled = walls;
    ms::SimulationOptions on, off;
    on.backend = off.backend = ms::BackendKind::CUDA;
    off.graphs = false;
    auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01, on);
    auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, off);
    for (int steps : {40, 13, 64, 7}) {
      a->run(steps);
      b->run(steps);
    }
    EXPECT_GE(a->graph_steps(), 96u) << "walls " << walls;
    EXPECT_EQ(b->graph_steps(), 0u);
    EXPECT_EQ(a->step(), b->step());
    EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
    const auto pa = a->particles(), pb = b->particles();
    ASSERT_EQ(pa.size(), pb.size());
    for (size_t i = 0; i < pa.size(); ++i) {
      ASSERT_EQ(pa.id[i], pb.id[i]);
      ASSERT_EQ(pa.x[i], pb.x[i]) << "walls " << walls << ", particle " << i;
      ASSERT_EQ(pa.z[i], pb.z[i]) << "walls " << walls << ", particle " << i;
      ASSERT_EQ(pa.vy[i], pb.vy[i]) << "walls " << walls << ", particle " << i;
    }
  }
}

// Several threads per particle in the density and force passes (SimulationOptions::
// lanes_per_particle) split each scan and add the lanes' sums: the same rho, phi and forces as one
// thread per particle up to the order of the sums, and the same wall corrections over 20 steps.
TEST_P(GpuVsCpu, LanesChangeOnlyTheOrderOfSums) {
  Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
  c.model.wall_model.enabled = true;
  const double tol = GetParam() == ms::Precision::Single ? 1e-5 : 1e-12;
  ms::SimulationOptions one;
  one.backend = ms::BackendKind::CUDA;
  one.lanes_per_particle = 1;
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01, one);
  const auto ra = a->densities(), pa = a->boundary_volume_fractions();
  const auto fa = a->forces();
  for (int lanes : {2, 4, 8}) {
    ms::SimulationOptions o = one;
    o.lanes_per_particle = lanes;
    auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, o);
    const auto rb = b->densities(), pb = b->boundary_volume_fractions();
    ASSERT_EQ(ra.size(), rb.size());
    for (size_t i = 0; i < ra.size(); ++i) {
      ASSERT_NEAR(ra[i], rb[i], tol * (1 + ra[i])) << lanes << " lanes, particle " << i;
      ASSERT_NEAR(pa[i], pb[i], tol) << lanes << " lanes, particle " << i;
    }
    EXPECT_LT(worst_force_difference(fa, b->forces()), 10 * tol) << lanes << " lanes";
  }
  ms::SimulationOptions four = one;
  four.lanes_per_particle = 4;
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, four);
  a->run(20);
  b->run(20);
  EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
  EXPECT_LT(worst_position_difference(a->particles(), b->particles()), 1e-4);
  ms::SimulationOptions bad = one;
  bad.lanes_per_particle = 3;
  EXPECT_THROW(ms::make_simulation(c.model, c.box, c.particles, 0.01, bad), mesorock::ConfigError);
}

// A wall 4 rc thick, as a rock's grains, under 8 rc of fluid: the frozen part's kept sums, the
// corrector before the sort and the neighbour list over many steps. rho and phi every 10 steps
// against the CPU's on the same positions; forces, corrections and trajectories over 20 steps.
TEST_P(GpuVsCpu, ThickWallAgreesWithTheCpuStepAfterStep) {
  Case c = fluid_and_wall(GetParam(), 78);
  c.model.wall_model.enabled = true;
  fill_over_wall(c, 9, 9, 12, 4, 3600, 5);
  ms::SimulationOptions gpu;
  gpu.backend = ms::BackendKind::CUDA;
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
  const double tol = GetParam() == ms::Precision::Single ? 2e-4 : 1e-10;
  // Every 10 steps: the GPU's sums (the frozen part's kept ones among them) against the CPU's on
  // the same positions.
  for (int round = 0; round < 3; ++round) {
    auto a = ms::make_simulation(c.model, c.box, b->particles(), 0.01);
    const auto ra = a->densities(), rb = b->densities();
    const auto pa = a->boundary_volume_fractions(), pb = b->boundary_volume_fractions();
    ASSERT_EQ(ra.size(), rb.size());
    for (size_t i = 0; i < ra.size(); ++i) {
      ASSERT_NEAR(ra[i], rb[i], tol * (1 + ra[i])) << "round " << round << ", particle " << i;
      ASSERT_NEAR(pa[i], pb[i], tol) << "round " << round << ", particle " << i;
    }
    if (round == 0) EXPECT_LT(worst_force_difference(a->forces(), b->forces()), 1e-5);
    b->run(10);
  }
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01);
  auto fresh = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
  a->run(20);
  fresh->run(20);
  EXPECT_EQ(a->wall_corrections(), fresh->wall_corrections());
  EXPECT_LT(worst_position_difference(a->particles(), fresh->particles()), 1e-4);
}

// The decomposed solver on one rank (DecompositionOptions::force): its migration and ghosts
// select particles on the device (CudaEngine::select, CUB over the flags). Over 20 steps with the
// wall model it must follow the single-rank solver to round-off, with the same corrections.
TEST_P(GpuVsCpu, DecomposedOnOneRankFollowsTheSingleRankRun) {
  Case c = mixed_case(GetParam(), ms::ConservativeKind::MDPD, ms::DensityKernelKind::Warren);
  c.model.wall_model.enabled = true;
  ms::SimulationOptions plain, decomposed;
  plain.backend = decomposed.backend = ms::BackendKind::CUDA;
  decomposed.decomposition.force = true;
  decomposed.comm = ms::make_self_communicator();
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01, plain);
  auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, decomposed);
  a->run(20);
  b->run(20);
  EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
  EXPECT_LT(worst_position_difference(a->particles(), b->particles()), 1e-4);
}

// A liquid compressed to rho = 30 has about 126 neighbours per particle: more than the GPU's
// neighbour list holds for one thread (72 slots) or for each of 2, 4 and 8 lanes (40, 24, 16).
// The lanes that overflow scan again in the force pass; the forces must still be the CPU's.
TEST_P(GpuVsCpu, NeighbourListOverflowStillGivesTheForces) {
  Case c = fluid_and_wall(GetParam(), 79);  // fluid only
  c.box.hi = {5, 5, 5};
  std::int64_t next = 0;
  ms::fill_random(c.particles, kFluid, {0, 0, 0}, {5, 5, 5}, 3750, 9, next);
  ms::assign_maxwell_velocities(c.particles, c.model, 1.0, 9);
  auto a = ms::make_simulation(c.model, c.box, c.particles, 0.01);
  const auto fa = a->forces();
  for (int lanes : {1, 2, 4, 8}) {
    ms::SimulationOptions gpu;
    gpu.backend = ms::BackendKind::CUDA;
    gpu.lanes_per_particle = lanes;
    auto b = ms::make_simulation(c.model, c.box, c.particles, 0.01, gpu);
    EXPECT_LT(worst_force_difference(fa, b->forces()), 1e-5) << lanes << " lanes";
  }
}

INSTANTIATE_TEST_SUITE_P(Precisions, GpuVsCpu,
                         ::testing::Values(ms::Precision::Single, ms::Precision::Double),
                         [](const auto& info) { return std::string(ms::to_string(info.param)); });

}  // namespace
