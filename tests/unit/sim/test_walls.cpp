// The wall model (Li et al. 2018; sim/wall_model.h): the flat-wall relations against an
// independent Monte Carlo integral, the boundary volume fraction against brute force, the
// corrector on a particle placed inside a wall, and a fluid pressed against a wall that leaks
// without the model and stays out with it. One body for every backend.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"
#include "sim/wall_model.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

// Monte Carlo over the unit ball: the cap d_z > h of the Lucy kernel W (BVF), and of
// w_D e_x^2 and w_D e_x^2 d_z with w_D = (1 - r)^2 (no-slip factor).
struct McCap {
  double phi, kappa;
};
McCap monte_carlo_cap(double h, int samples, std::uint32_t seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double whole = 0, cap = 0, j0 = 0, j1 = 0;
  for (int k = 0; k < samples; ++k) {
    const double x = u(gen), y = u(gen), z = u(gen);
    const double r = std::sqrt(x * x + y * y + z * z);
    if (r >= 1 || r == 0) continue;
    const double w = (1 + 3 * r) * std::pow(1 - r, 3);  // Lucy, unnormalised
    const double wd = (1 - r) * (1 - r);
    whole += w;
    if (z > h) {
      cap += w;
      j0 += wd * x * x / (r * r);
      j1 += wd * x * x / (r * r) * z;
    }
  }
  return {cap / whole, j1 / (h * j0)};
}

TEST(WallModelTable, FlatWallRelationsMatchAnIndependentIntegral) {
  // phi = 1/2 on the surface, 0 beyond the cutoff; kappa -> 1 far from the wall.
  EXPECT_NEAR(ms::flat_wall_relation(0.0).phi, 0.5, 1e-3);
  EXPECT_EQ(ms::flat_wall_relation(1.0).phi, 0.0);
  for (double h : {0.1, 0.3, 0.6}) {
    const ms::FlatWallRelation f = ms::flat_wall_relation(h);
    const McCap mc = monte_carlo_cap(h, 4000000, 11);
    EXPECT_NEAR(f.phi, mc.phi, 0.01 * mc.phi + 1e-3) << "h " << h;
    EXPECT_NEAR(f.kappa, mc.kappa, 0.02 * mc.kappa) << "h " << h;
  }
}

// The closed form used in docs/walls.md and the authors' code equals the numerical cap integral.
TEST(WallModelTable, ClosedFormFlatWallPhi) {
  for (double h : {0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0, 1.5})
    EXPECT_NEAR(ms::flat_wall_phi(h), ms::flat_wall_relation(h).phi, 2e-4) << "h " << h;
  EXPECT_NEAR(ms::flat_wall_phi(0.1), 0.371, 1e-3);
}

// The default cap 8.2 of WallModelSpec is kappa at the authors' floor h = 0.025 rc; their fit
// 1 + 0.187 (1/h - 1) - 0.093 (1 - h)^3 agrees with the integral to 1% where it matters.
TEST(WallModelTable, DefaultCapIsKappaAtTheAuthorsFloor) {
  EXPECT_NEAR(ms::flat_wall_relation(ms::kMinWallDistance).kappa,
              ms::WallModelSpec{}.max_dissipation_factor,
              0.02 * ms::WallModelSpec{}.max_dissipation_factor);
  for (double h : {0.05, 0.1, 0.2, 0.5}) {
    const double fit = 1 + 0.187 * (1 / h - 1) - 0.093 * std::pow(1 - h, 3);
    EXPECT_NEAR(ms::flat_wall_relation(h).kappa, fit, 0.01 * fit) << "h " << h;
  }
}

TEST(WallModelTable, KappaGrowsTowardsTheWallAndIsCapped) {
  const std::vector<double> t = ms::tabulate_kappa(256, 0.5, 5.0);
  ASSERT_EQ(t.size(), 256u);
  EXPECT_NEAR(t.front(), 1.0, 0.05);  // phi = 0: beyond the cutoff
  EXPECT_DOUBLE_EQ(t.back(), 5.0);    // phi = 1/2: on the surface, capped
  for (size_t k = 1; k < t.size(); ++k) EXPECT_GE(t[k], t[k - 1] - 1e-9) << k;
  // Between: kappa(phi(h)) = kappa(h) read back at h = 0.2 (phi 0.254).
  const ms::FlatWallRelation f = ms::flat_wall_relation(0.2);
  const double u = f.phi / 0.5 * 255;
  const auto k = static_cast<size_t>(u);
  const double read = t[k] + (u - k) * (t[k + 1] - t[k]);
  EXPECT_NEAR(read, f.kappa, 0.01 * f.kappa);
}

struct WallSetup {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// A frozen wall lattice (density 8) filling z in [0, wall_top), fluid above it up to a reflective
// face at the top; x and y periodic.
WallSetup wall_and_fluid(bool wall_model, double wall_top, double fluid_count, double gz,
                         std::uint64_t seed) {
  WallSetup s;
  s.model.conservative = ms::ConservativeKind::MDPD;
  s.model.seed = seed;
  const int fluid = s.model.add_type({"fluid", false, {0, 0, gz}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {-40, 25, 4.5});
  s.model.set_pair(fluid, wall, {-30, 25, 4.5});
  s.model.set_pair(wall, wall, {-40, 25, 4.5});
  s.model.wall_model.enabled = wall_model;
  s.box.hi = {6, 6, wall_top + 6};
  s.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_lattice(s.particles, wall, {0, 0, 0}, {6, 6, wall_top}, 8, next);
  ms::fill_random(s.particles, fluid, {0, 0, wall_top + 0.2}, s.box.hi,
                  static_cast<std::int64_t>(fluid_count), seed, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}

class Walls : public OnEveryBackend {};

TEST_P(Walls, BoundaryVolumeFractionMatchesBruteForce) {
  for (auto precision : {ms::Precision::Double, ms::Precision::Single}) {
    WallSetup s = wall_and_fluid(true, 2.0, 1200, 0.0, 3);
    s.model.precision = precision;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    const ms::ParticleSet p = sim->particles();
    const std::vector<double> phi = sim->boundary_volume_fractions();
    ASSERT_EQ(phi.size(), p.size());
    const int wall = s.model.type_index("wall");
    const double tol = precision == ms::Precision::Double ? 1e-10 : 1e-5;
    int near_wall = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      double sum_wall = 0;
      for (size_t j = 0; j < p.size(); ++j) {
        if (i == j) continue;
        double d[3] = {p.x[i] - p.x[j], p.y[i] - p.y[j], p.z[i] - p.z[j]};
        for (int a = 0; a < 2; ++a) d[a] -= s.box.length(a) * std::round(d[a] / s.box.length(a));
        const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (r >= 1) continue;
        if (p.type[j] == wall) sum_wall += 105 / (16 * M_PI) * (1 + 3 * r) * std::pow(1 - r, 3);
      }
      // The lattice has the default wall density n_w = 8.
      const double expected = p.type[i] == wall ? 0.0 : sum_wall / 8.0;
      ASSERT_NEAR(phi[i], expected, tol) << "particle " << i;
      if (expected > 0.02) ++near_wall;
    }
    EXPECT_GT(near_wall, 40);  // the comparison covered particles that see the wall
  }
}

// One fluid particle 0.1 rc inside a flat wall lattice, at a lattice-cell centre in x and y so
// that the wall-side normal is exactly +z by symmetry.
WallSetup particle_inside_wall(double vz, ms::WallReflection reflection) {
  WallSetup s;
  s.model.conservative = ms::ConservativeKind::MDPD;
  const int fluid = s.model.add_type({"fluid", false, {0, 0, 0}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {-40, 25, 4.5});
  s.model.set_pair(fluid, wall, {-40, 25, 4.5});
  s.model.set_pair(wall, wall, {-40, 25, 4.5});
  s.model.wall_model.enabled = true;
  s.model.wall_model.reflection = reflection;
  s.box.hi = {4, 4, 6};
  s.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_lattice(s.particles, wall, {0, 0, 0}, {4, 4, 2}, 8, next);  // spacing 0.5
  s.particles.add(2.25, 2.25, 1.9, 0.3, -0.2, vz, fluid, next++);
  return s;
}

TEST_P(Walls, CorrectorReflectsAParticleMovingIntoTheWall) {
  for (auto reflection : {ms::WallReflection::Specular, ms::WallReflection::Li2018}) {
    WallSetup s = particle_inside_wall(-1.0, reflection);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    EXPECT_EQ(sim->wall_corrections(), 1u);
    const ms::ParticleSet p = sim->particles();
    const size_t i = p.size() - 1;
    EXPECT_GT(sim->boundary_volume_fractions()[i], 0.5);
    EXPECT_NEAR(p.vz[i], 1.0, 1e-9);
    EXPECT_NEAR(p.z[i], 1.9 + 0.01 * 2.0, 1e-9);
    const double vx = reflection == ms::WallReflection::Specular ? 0.3 : -0.3;
    const double vy = reflection == ms::WallReflection::Specular ? -0.2 : 0.2;
    EXPECT_NEAR(p.vx[i], vx, 1e-9) << ms::to_string(reflection);
    EXPECT_NEAR(p.vy[i], vy, 1e-9) << ms::to_string(reflection);
    EXPECT_NEAR(p.x[i], 2.25 + 0.01 * (vx - 0.3), 1e-9);
  }
}

// A particle inside the wall that is already moving out keeps its normal velocity; the authors'
// rule reverses its tangential velocity, the specular one leaves it alone.
TEST_P(Walls, CorrectorKeepsTheOutwardVelocityOfALeavingParticle) {
  {
    WallSetup s = particle_inside_wall(+1.0, ms::WallReflection::Specular);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    EXPECT_EQ(sim->wall_corrections(), 0u);
    const ms::ParticleSet p = sim->particles();
    EXPECT_NEAR(p.vz[p.size() - 1], 1.0, 1e-12);
    EXPECT_NEAR(p.z[p.size() - 1], 1.9, 1e-12);
  }
  {
    WallSetup s = particle_inside_wall(+1.0, ms::WallReflection::Li2018);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    EXPECT_EQ(sim->wall_corrections(), 1u);
    const ms::ParticleSet p = sim->particles();
    const size_t i = p.size() - 1;
    EXPECT_NEAR(p.vz[i], 1.0, 1e-9);
    EXPECT_NEAR(p.vx[i], -0.3, 1e-9);
    EXPECT_NEAR(p.vy[i], 0.2, 1e-9);
    EXPECT_NEAR(p.z[i], 1.9, 1e-9);
    EXPECT_NEAR(p.x[i], 2.25 - 0.01 * 0.6, 1e-9);
  }
}

// A soft DPD fluid (density 3) pushed onto a sparse, weakly repulsive wall 1.5 rc thick (density
// 4, a_FW = 5) by a body force for 800 steps: without the wall model fluid particles end up deep
// in the wall; with it none sits 0.5 rc or more inside (the corrector acts within a step of
// phi = 1/2, the wall surface).
TEST_P(Walls, FluidPressedOntoAWallLeaksWithoutTheModelAndNotWithIt) {
  int deep[2] = {0, 0};
  for (int with_model : {0, 1}) {
    WallSetup s;
    s.model.conservative = ms::ConservativeKind::DPD;
    s.model.seed = 9;
    const int fluid = s.model.add_type({"fluid", false, {0, 0, -1.0}});
    const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
    s.model.set_pair(fluid, fluid, {25, 0, 4.5});
    s.model.set_pair(fluid, wall, {5, 0, 4.5});
    s.model.set_pair(wall, wall, {25, 0, 4.5});
    s.model.wall_model.enabled = with_model == 1;
    s.model.wall_model.wall_density = 4;
    s.box.hi = {5, 5, 7.5};
    s.box.periodic = {true, true, false};
    std::int64_t next = 0;
    ms::fill_lattice(s.particles, wall, {0, 0, 0}, {5, 5, 1.5}, 4, next);
    ms::fill_random(s.particles, fluid, {0, 0, 1.7}, s.box.hi, 5 * 5 * 5 * 3, 9, next);
    ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 9);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    sim->run(800);
    const ms::ParticleSet p = sim->particles();
    for (size_t i = 0; i < p.size(); ++i)
      if (p.type[i] == fluid && p.z[i] < 1.0) ++deep[with_model];
    if (with_model) EXPECT_GT(sim->wall_corrections(), 0u);
  }
  std::printf(
      "fluid particles 0.5 rc or more inside the wall: %d without the wall model, %d with\n",
      deep[0], deep[1]);
  EXPECT_GT(deep[0], 10) << "the set-up must press fluid into an unprotected wall";
  EXPECT_EQ(deep[1], 0) << "fluid particles 0.5 rc or more inside the wall";
}

// The frozen part (SimulationOptions::frozen_part; ARCHITECTURE.md): the frozen particles stored
// apart and sorted once, their sums over frozen neighbours kept. A wall 4 rc thick under fluid,
// as a rock's grains: rho, phi and the forces those of the run without it up to the order of the
// sums, the same corrections and trajectories over 30 steps (with a sort every step and with a
// reorder interval), and on the CPU the same bits on one and two threads.
TEST_P(Walls, TheFrozenPartChangesOnlyTheOrderOfSums) {
  WallSetup s = wall_and_fluid(true, 4, 6 * 6 * 5.8 * 6.5, -0.5, 17);
  for (const int reorder : {1, 10}) {
    ms::SimulationOptions on = options(), off = options();
    on.reorder_every = off.reorder_every = reorder;
    on.skin = off.skin = reorder > 1 ? 0.3 : 0;
    off.frozen_part = false;
    auto a = ms::make_simulation(s.model, s.box, s.particles, 0.01, on);
    auto b = ms::make_simulation(s.model, s.box, s.particles, 0.01, off);
    const auto ra = a->densities(), rb = b->densities();
    const auto pa = a->boundary_volume_fractions(), pb = b->boundary_volume_fractions();
    const auto fa = a->forces(), fb = b->forces();
    ASSERT_EQ(ra.size(), rb.size());
    double phi_max = 0;
    for (size_t i = 0; i < ra.size(); ++i) {
      ASSERT_NEAR(ra[i], rb[i], 1e-12 * (1 + ra[i])) << "particle " << i;
      ASSERT_NEAR(pa[i], pb[i], 1e-12) << "particle " << i;
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(fa[c][i], fb[c][i], 1e-9) << "particle " << i;
      phi_max = std::max(phi_max, pa[i]);
    }
    EXPECT_GT(phi_max, 0.1) << "fluid must touch the wall";
    a->run(30);
    b->run(30);
    EXPECT_EQ(a->wall_corrections(), b->wall_corrections()) << "reorder " << reorder;
    const ms::ParticleSet qa = a->particles(), qb = b->particles();
    for (size_t i = 0; i < qa.size(); ++i) {
      ASSERT_EQ(qa.id[i], qb.id[i]);
      ASSERT_NEAR(qa.z[i], qb.z[i], 1e-7) << "reorder " << reorder << ", particle " << i;
      ASSERT_NEAR(qa.vx[i], qb.vx[i], 1e-5) << "reorder " << reorder << ", particle " << i;
    }
  }
  if (GetParam() != ms::BackendKind::CPU) return;
  ms::SimulationOptions one = options(), two = options();
  one.threads = 1;
  two.threads = 2;
  auto a = ms::make_simulation(s.model, s.box, s.particles, 0.01, one);
  auto b = ms::make_simulation(s.model, s.box, s.particles, 0.01, two);
  a->run(30);
  b->run(30);
  const ms::ParticleSet qa = a->particles(), qb = b->particles();
  EXPECT_EQ(qa.x, qb.x);
  EXPECT_EQ(qa.vz, qb.vz);
  EXPECT_EQ(a->densities(), b->densities());
}

TEST_P(Walls, InvalidWallModelsAreRefused) {
  WallSetup s = wall_and_fluid(true, 1.5, 100, 0, 1);
  s.model.thermostat = false;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = wall_and_fluid(true, 1.5, 100, 0, 1);
  s.model.types[1].frozen = false;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = wall_and_fluid(true, 1.5, 100, 0, 1);
  s.model.wall_model.penetration_threshold = 1.5;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  s = wall_and_fluid(true, 1.5, 100, 0, 1);
  s.model.wall_model.wall_density = 0;
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, 0.01, options()),
               mesorock::ConfigError);
  // One check for the scene reader and the sim (sim::validate_wall_model): the message names the
  // scene key and quotes the value, infinite values included.
  s = wall_and_fluid(true, 1.5, 100, 0, 1);
  s.model.wall_model.wall_density = INFINITY;
  try {
    ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    ADD_FAILURE() << "an infinite wall density was accepted";
  } catch (const mesorock::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "walls.wall_density: must be positive and finite (got inf)");
  }
}

MESOROCK_ON_EVERY_BACKEND(Walls);

}  // namespace
