// Binned observables and their time averages; the reverse-Poiseuille body force.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/observables.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

class Binning : public OnEveryBackend {};
class ReversedForce : public OnEveryBackend {};

ms::Model two_type_fluid() {
  ms::Model m;
  m.conservative = ms::ConservativeKind::MDPD;
  m.seed = 3;
  const int a = m.add_type({"a", false, {0, 0, 0}});
  const int b = m.add_type({"b", false, {0, 0, 0}});
  const int w = m.add_type({"wall", true, {0, 0, 0}});
  for (int i : {a, b, w})
    for (int j : {a, b, w}) m.set_pair(i, j, {-40, 25, 4.5});
  return m;
}

// Brute-force bin sums straight from the particle list.
std::vector<double> brute_bins(const ms::ParticleSet& p, const ms::BinGrid& g) {
  std::vector<double> s(g.count() * ms::kBinFields, 0.0);
  for (size_t i = 0; i < p.size(); ++i) {
    if (!((g.type_mask >> p.type[i]) & 1u)) continue;
    const double c[3] = {p.x[i], p.y[i], p.z[i]};
    int k[3];
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const double u = (c[a] - g.lo[a]) / g.width(a);
      k[a] = static_cast<int>(std::floor(u));
      inside = inside && u >= 0 && k[a] < g.cells[a];
    }
    if (!inside) continue;
    double* b = &s[((k[2] * g.cells[1] + k[1]) * g.cells[0] + k[0]) * ms::kBinFields];
    const double v[3] = {p.vx[i], p.vy[i], p.vz[i]};
    b[ms::kBinCount] += 1;
    for (int a = 0; a < 3; ++a) {
      b[ms::kBinVx + a] += v[a];
      b[ms::kBinVxx + a] += v[a] * v[a];
    }
  }
  return s;
}

}  // namespace

TEST_P(Binning, SumsMatchBruteForceOnGridsAndProfiles) {
  ms::Model m = two_type_fluid();
  ms::BoxSpec box;
  box.lo = {-3, 0, 1};
  box.hi = {5, 6, 8};
  ms::ParticleSet p;
  std::int64_t next = 0;
  ms::fill_random(p, 0, box.lo, box.hi, 900, 7, next);
  ms::fill_random(p, 1, box.lo, box.hi, 400, 8, next);
  ms::fill_random(p, 2, box.lo, box.hi, 300, 9, next);
  ms::assign_maxwell_velocities(p, m, 1.0, 11);
  auto sim = ms::make_simulation(m, box, p, 0.01, options());
  sim->run(5);
  const ms::ParticleSet now = sim->particles();

  ms::BinGrid grid;
  grid.cells = {4, 3, 5};
  grid.lo = box.lo;
  grid.hi = box.hi;
  grid.type_mask = 0b011;  // the two mobile types, not the wall
  ms::BinGrid profile = ms::BinGrid::profile(2, 7, box.lo, box.hi);
  profile.type_mask = 0b010;  // type b only
  ms::BinGrid part = grid;    // a sub-region: particles outside are not counted
  part.lo = {0, 1, 2};
  part.hi = {4, 5, 6};
  ms::BinGrid one = part;  // one bin (a region's sums, the sweep's flux): summed per block
  one.cells = {1, 1, 1};
  one.type_mask = 0b001;
  ms::BinGrid whole = grid;
  whole.cells = {1, 1, 1};
  for (const ms::BinGrid& g : {grid, profile, part, one, whole}) {
    const auto got = sim->bin_sums(g);
    const auto want = brute_bins(now, g);
    ASSERT_EQ(got.size(), want.size());
    for (size_t k = 0; k < got.size(); ++k)
      EXPECT_NEAR(got[k], want[k], 1e-9 * (1 + std::abs(want[k])));
  }
  EXPECT_EQ(sim->bin_sums(whole), sim->bin_sums(whole)) << "one bin: the same bits every time";
  double counted = 0;
  const auto all = sim->bin_sums(grid);
  for (size_t b = 0; b < grid.count(); ++b) counted += all[b * ms::kBinFields];
  EXPECT_EQ(counted, 1300.0);  // every mobile particle, no wall particle
}

TEST_P(Binning, RejectsEmptyGrids) {
  ms::Model m = two_type_fluid();
  ms::BoxSpec box;
  ms::ParticleSet p;
  p.add(1, 1, 1, 0, 0, 0, 0, 0);
  auto sim = ms::make_simulation(m, box, p, 0.01, options());
  ms::BinGrid g;
  g.cells = {0, 1, 1};
  EXPECT_THROW(sim->bin_sums(g), mesorock::ConfigError);
}

// A lone particle in each half of a reverse-Poiseuille box feels +g below the mid-plane and -g
// above it: v = s g t exactly without other forces.
TEST_P(ReversedForce, SignFlipsAtTheMidplane) {
  ms::Model m;
  m.conservative = ms::ConservativeKind::DPD;
  m.thermostat = false;
  const int t = m.add_type({"fluid", false, {0.3, 0.0, 0.0}});
  m.set_pair(t, t, {25, 0, 0});
  m.body_force_profile = ms::BodyForceProfile::Reversed;
  m.body_force_axis = 2;
  ms::BoxSpec box;
  box.lo = {0, 0, -4};
  box.hi = {10, 10, 6};  // mid-plane z = 1
  ms::ParticleSet p;
  p.add(2, 2, -1, 0, 0, 0, t, 0);
  p.add(7, 7, 3, 0, 0, 0, t, 1);
  auto sim = ms::make_simulation(m, box, p, 0.01, options());
  EXPECT_NE(sim->pass_name().find("body_force=reversed"), std::string::npos) << sim->pass_name();
  sim->run(100);
  const auto q = sim->particles();
  EXPECT_NEAR(q.vx[0], 0.3, 1e-12);
  EXPECT_NEAR(q.vx[1], -0.3, 1e-12);
  EXPECT_EQ(q.vz[0], 0.0);
}

MESOROCK_ON_EVERY_BACKEND(Binning);
MESOROCK_ON_EVERY_BACKEND(ReversedForce);

// Block averaging: the mean is over every sample; the error of uncorrelated samples matches the
// textbook sigma / sqrt(n) within its own sampling uncertainty; block merging keeps the count of
// blocks between max/2 and max.
TEST(BinnedAverage, MeansAndErrorsOfKnownSeries) {
  ms::BinGrid g = ms::BinGrid::profile(0, 2, {0, 0, 0}, {2, 1, 1});  // bin volume 1
  ms::BinnedAverage avg(g, 32);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.5);
  const int samples = 5000;
  double sum_v = 0;
  for (int k = 0; k < samples; ++k) {
    std::vector<double> s(2 * ms::kBinFields, 0.0);
    // Bin 0: 10 particles with mean velocity 1 + noise; bin 1: 4 particles at rest.
    const double v = 1.0 + noise(rng);
    sum_v += v;
    s[ms::kBinCount] = 10;
    s[ms::kBinVx] = 10 * v;
    s[ms::kBinVxx] = 10 * v * v;
    s[ms::kBinFields + ms::kBinCount] = 4;
    avg.add(s);
  }
  EXPECT_EQ(avg.samples(), static_cast<size_t>(samples));
  EXPECT_GE(avg.blocks(), 16u);
  EXPECT_LT(avg.blocks(), 32u);
  const auto rho = avg.density();
  EXPECT_DOUBLE_EQ(rho.mean[0], 10.0);
  EXPECT_DOUBLE_EQ(rho.mean[1], 4.0);
  EXPECT_DOUBLE_EQ(rho.error[0], 0.0);
  const auto u = avg.velocity(0);
  EXPECT_NEAR(u.mean[0], sum_v / samples, 1e-12);
  const double expected = 0.5 / std::sqrt(static_cast<double>(samples));
  // With ~16-31 blocks the error estimate itself scatters by about 1/sqrt(2 * blocks) ~ 15%.
  EXPECT_NEAR(u.error[0], expected, 0.45 * expected);
  EXPECT_EQ(u.mean[1], 0.0);
  // Temperature relative to the bin's mean velocity: all particles of a sample share v, so the
  // spread within a sample is 0, but the spread across samples counts: <v^2> - <v>^2 = 0.25 / 3.
  const auto T = avg.temperature();
  EXPECT_NEAR(T.mean[0], 0.25 / 3.0, 0.01);
}

TEST(BinnedAverage, FewSamplesGiveNoErrorBarRatherThanAWrongOne) {
  ms::BinGrid g;
  g.hi = {1, 1, 1};
  ms::BinnedAverage avg(g, 8);
  std::vector<double> s(ms::kBinFields, 0.0);
  s[ms::kBinCount] = 3;
  avg.add(s);
  EXPECT_EQ(avg.blocks(), 1u);
  EXPECT_EQ(avg.density().error[0], 0.0);
  EXPECT_EQ(avg.density().mean[0], 3.0);
}
