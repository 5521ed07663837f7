// Whole-step tests through the public Simulation API, one body for every backend.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct FluidSetup {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

FluidSetup random_fluid(const std::array<double, 3>& L, double rho, bool periodic, bool thermostat,
                        ms::DensityKernelKind kernel = ms::DensityKernelKind::Warren,
                        std::uint64_t seed = 5) {
  FluidSetup s;
  s.model.conservative = ms::ConservativeKind::MDPD;
  s.model.density_kernel = kernel;
  s.model.thermostat = thermostat;
  s.model.seed = seed;
  const int t = s.model.add_type({"fluid", false, {0, 0, 0}});
  s.model.set_pair(t, t, {-40, 25, thermostat ? 4.5 : 0.0});
  s.box.hi = L;
  s.box.periodic = {periodic, periodic, periodic};
  std::int64_t next = 0;
  const auto n = static_cast<std::int64_t>(rho * L[0] * L[1] * L[2]);
  ms::fill_random(s.particles, t, s.box.lo, s.box.hi, n, seed, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}

double separation(const ms::ParticleSet& p, const ms::BoxSpec& box, size_t i, size_t j, int a) {
  const double ci[3] = {p.x[i], p.y[i], p.z[i]};
  const double cj[3] = {p.x[j], p.y[j], p.z[j]};
  double d = ci[a] - cj[a];
  if (box.periodic[a]) d -= box.length(a) * std::round(d / box.length(a));
  return d;
}

// Brute-force O(N^2) density with the papers' kernel.
std::vector<double> brute_density(const ms::ParticleSet& p, const ms::BoxSpec& box, double rd) {
  std::vector<double> rho(p.size(), 0.0);
  const double norm = 15.0 / (2 * M_PI * rd * rd * rd);
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = 0; j < p.size(); ++j) {
      if (i == j) continue;
      double r2 = 0;
      for (int a = 0; a < 3; ++a) r2 += std::pow(separation(p, box, i, j, a), 2);
      const double r = std::sqrt(r2);
      if (r < rd) rho[i] += norm * (1 - r / rd) * (1 - r / rd);
    }
  return rho;
}

// Total mDPD potential energy: sum_{i<j} A/2 (1 - r)^2 + sum_i pi rd^4 B / 30 rho_i^2, whose
// negative gradient is the conservative force with the papers' density kernel (Warren 2003).
double mdpd_energy(const ms::ParticleSet& p, const ms::BoxSpec& box, double A, double B,
                   double rd) {
  double u = 0;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) {
      double r2 = 0;
      for (int a = 0; a < 3; ++a) r2 += std::pow(separation(p, box, i, j, a), 2);
      const double r = std::sqrt(r2);
      if (r < 1) u += 0.5 * A * (1 - r) * (1 - r);
    }
  for (double rho : brute_density(p, box, rd)) u += M_PI * std::pow(rd, 4) * B / 30 * rho * rho;
  return u;
}

class CellList : public OnEveryBackend {};

// Boxes with 1, 2 and 3+ cells per axis, periodic and reflective: the cell-list density equals
// the brute-force one, so no pair is missed or counted twice.
// Every stencil depth: with c cells per rc an axis needs 2c + 1 cells before the stencil stops
// covering it whole, so these boxes exercise both the shifted and the minimum-image paths.
TEST_P(CellList, DensityMatchesBruteForceForEveryBoxShape) {
  for (int cells_per_rc : {1, 2, 3}) {
    for (bool periodic : {true, false}) {
      for (const auto& L :
           {std::array<double, 3>{2.0, 2.0, 2.0}, std::array<double, 3>{2.5, 3.2, 4.7},
            std::array<double, 3>{6.0, 2.0, 3.0}, std::array<double, 3>{1.5, 5.0, 2.0}}) {
        if (periodic && L[0] < 2) continue;  // periodic edges must be >= 2 rc
        FluidSetup s = random_fluid(L, 6.0, periodic, false);
        ms::SimulationOptions o = options();
        o.cells_per_cutoff = cells_per_rc;
        auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
        const auto rho = sim->densities();
        const auto ref = brute_density(sim->particles(), s.box, 0.75);
        for (size_t i = 0; i < ref.size(); ++i)
          ASSERT_NEAR(rho[i], ref[i], 1e-9 * (1 + ref[i]))
              << "particle " << i << " box " << L[0] << "x" << L[1] << "x" << L[2]
              << (periodic ? " periodic" : " reflective") << ", " << cells_per_rc
              << " cells per rc";
      }
    }
  }
}

// The force pass sees the same neighbours whatever the stencil: forces agree to round-off (the
// summation order differs) between 1, 2 and 3 cells per rc.
TEST_P(CellList, ForcesDoNotDependOnTheStencil) {
  FluidSetup s = random_fluid({5.0, 2.5, 4.2}, 7.0, true, true);
  std::array<std::vector<double>, 3> ref;
  for (int cells_per_rc : {1, 2, 3}) {
    ms::SimulationOptions o = options();
    o.cells_per_cutoff = cells_per_rc;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    const auto f = sim->forces();
    if (cells_per_rc == 1) {
      ref = f;
      continue;
    }
    for (int a = 0; a < 3; ++a)
      for (size_t i = 0; i < f[a].size(); ++i)
        ASSERT_NEAR(f[a][i], ref[a][i], 1e-9 * (1 + std::abs(ref[a][i])))
            << "particle " << i << " axis " << a << ", " << cells_per_rc << " cells per rc";
  }
}

class Forces : public OnEveryBackend {};

TEST_P(Forces, MDPDConservativeForceIsMinusGradientOfTheManyBodyPotential) {
  FluidSetup s = random_fluid({3.0, 3.0, 3.0}, 5.0, true, false);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  const auto f = sim->forces();
  const double h = 1e-6;
  for (size_t k : {size_t(0), size_t(7), size_t(42), size_t(100)}) {
    for (int a = 0; a < 3; ++a) {
      ms::ParticleSet plus = s.particles, minus = s.particles;
      std::vector<double>* cp[3] = {&plus.x, &plus.y, &plus.z};
      std::vector<double>* cm[3] = {&minus.x, &minus.y, &minus.z};
      (*cp[a])[k] += h;
      (*cm[a])[k] -= h;
      const double numeric =
          -(mdpd_energy(plus, s.box, -40, 25, 0.75) - mdpd_energy(minus, s.box, -40, 25, 0.75)) /
          (2 * h);
      EXPECT_NEAR(f[a][k], numeric, 1e-5 * (1 + std::abs(numeric)))
          << "particle " << k << " axis " << a;
    }
  }
}

TEST_P(Forces, SumToZeroWithThermostat) {
  FluidSetup s = random_fluid({4.0, 4.0, 4.0}, 7.0, true, true);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  sim->run(3);
  const auto f = sim->forces();
  double sum[3] = {0, 0, 0}, mag = 0;
  for (int a = 0; a < 3; ++a)
    for (double v : f[a]) sum[a] += v, mag += std::abs(v);
  for (int a = 0; a < 3; ++a) EXPECT_LT(std::abs(sum[a]), 1e-11 * mag) << "axis " << a;
}

class Integration : public OnEveryBackend {};

TEST_P(Integration, SameSeedSameTrajectoryAndDifferentSeedDiffers) {
  auto run = [&](std::uint64_t seed) {
    FluidSetup s = random_fluid({4.0, 4.0, 4.0}, 7.0, true, true, ms::DensityKernelKind::Warren, 5);
    s.model.seed = seed;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    sim->run(50);
    return sim->particles();
  };
  const auto a = run(1), b = run(1), c = run(2);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.vz, b.vz);
  EXPECT_NE(a.x, c.x);
}

TEST_P(Integration, FrozenParticlesStayAndBodyForceAccelerates) {
  ms::Model m;
  m.conservative = ms::ConservativeKind::DPD;
  m.thermostat = false;
  const int fluid = m.add_type({"fluid", false, {0.0, 0.0, 0.5}});
  const int wall = m.add_type({"wall", true, {0.0, 0.0, 0.5}});
  for (int a : {fluid, wall})
    for (int b : {fluid, wall}) m.set_pair(a, b, {25, 0, 0});
  ms::BoxSpec box;
  box.hi = {10, 10, 10};
  ms::ParticleSet p;
  p.add(2, 2, 2, 0, 0, 0, fluid, 0);  // isolated: only the body force acts
  p.add(7, 7, 7, 0.1, 0, 0, wall, 1);
  auto sim = ms::make_simulation(m, box, p, 0.01, options());
  sim->run(100);
  const auto q = sim->particles();
  EXPECT_NEAR(q.vz[0], 0.5 * 1.0, 1e-12);           // v = g t
  EXPECT_NEAR(q.z[0], 2 + 0.5 * 0.5 * 1.0, 1e-12);  // z = z0 + g t^2 / 2
  EXPECT_EQ(q.x[1], 7.0);
  EXPECT_EQ(q.z[1], 7.0);
}

TEST_P(Integration, ReflectiveFacesKeepParticlesInside) {
  FluidSetup s = random_fluid({4.0, 3.0, 5.0}, 6.5, false, true);
  for (auto& v : s.particles.vx) v *= 5;  // hot: many wall hits
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  sim->run(200);
  const auto q = sim->particles();
  for (size_t i = 0; i < q.size(); ++i) {
    ASSERT_GE(q.x[i], 0.0);
    ASSERT_LT(q.x[i], 4.0);
    ASSERT_GE(q.z[i], 0.0);
    ASSERT_LT(q.z[i], 5.0);
  }
}

MESOROCK_ON_EVERY_BACKEND(CellList);
MESOROCK_ON_EVERY_BACKEND(Forces);
MESOROCK_ON_EVERY_BACKEND(Integration);

// The full state and the full stress tensor (every part, every component), bit for bit, at 1, 2
// and 3 threads. The stress once summed per-thread partials under `omp critical`, so it depended
// on the scheduling at round-off (the trajectory did not).
TEST(CpuBackend, ThreadCountChangesNeitherTheTrajectoryNorTheStress) {
  struct Outcome {
    ms::ParticleSet particles;
    ms::StressSample stress;
  };
  auto run = [&](int threads) {
    FluidSetup s = random_fluid({6.0, 6.0, 6.0}, 7.0, true, true);  // 1512 particles
    ms::SimulationOptions o;
    o.threads = threads;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    sim->run(40);
    return Outcome{sim->particles(), sim->stress()};
  };
  const Outcome one = run(1);
  for (int threads : {2, 3}) {
    const Outcome other = run(threads);
    const ms::ParticleSet &a = one.particles, &b = other.particles;
    EXPECT_EQ(a.id, b.id) << threads;
    EXPECT_EQ(a.x, b.x) << threads;
    EXPECT_EQ(a.y, b.y) << threads;
    EXPECT_EQ(a.z, b.z) << threads;
    EXPECT_EQ(a.vx, b.vx) << threads;
    EXPECT_EQ(a.vy, b.vy) << threads;
    EXPECT_EQ(a.vz, b.vz) << threads;
    EXPECT_EQ(one.stress.kinetic, other.stress.kinetic) << threads;
    EXPECT_EQ(one.stress.conservative, other.stress.conservative) << threads;
    EXPECT_EQ(one.stress.dissipative, other.stress.dissipative) << threads;
    EXPECT_EQ(one.stress.random, other.stress.random) << threads;
  }
}

TEST(Simulation, RejectsBadInputWithConfigError) {
  FluidSetup s = random_fluid({4.0, 4.0, 4.0}, 3.0, true, true);
  {
    auto b = s.box;
    b.hi[1] = 1.5;  // periodic edge < 2 rc
    EXPECT_THROW(ms::make_simulation(s.model, b, s.particles, 0.01), mesorock::ConfigError);
  }
  {
    auto p = s.particles;
    p.x[3] = std::nan("");
    EXPECT_THROW(ms::make_simulation(s.model, s.box, p, 0.01), mesorock::ConfigError);
  }
  {
    auto p = s.particles;
    p.type[0] = 5;
    EXPECT_THROW(ms::make_simulation(s.model, s.box, p, 0.01), mesorock::ConfigError);
  }
  EXPECT_THROW(ms::make_simulation(s.model, s.box, s.particles, -0.01), mesorock::ConfigError);
  {
    auto m = s.model;
    m.pair(0, 0).gamma = -1;
    EXPECT_THROW(ms::make_simulation(m, s.box, s.particles, 0.01), mesorock::ConfigError);
  }
}

}  // namespace
