// The GPU's scattering sums pass (FrozenDensityScatter, sim/kernels.h), run here on one thread:
// the mobile part alone is visited, each weight of a frozen neighbour added to that neighbour's
// fixed-point sum, then finish_scattered_sums. Against the gather (each frozen particle scanning
// its mobile neighbours, what the pass did before): every mobile particle's rho and phi keep
// their bits, every frozen particle's phi too, and its rho agrees to the fixed point's and the
// Real's round-off. The fixed-point sums are left at zero for the next step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/kernels.h"
#include "sim/stepper.h"
#include "sim/terms.h"
#include "unit/sim/wall_scene.h"

namespace ms = mesorock::sim;

namespace {

using mesorock::test::Case;
using mesorock::test::WallScene;

template <class Real>
class FrozenScatterTest : public ::testing::Test {};
using Reals = ::testing::Types<float, double>;
TYPED_TEST_SUITE(FrozenScatterTest, Reals);

template <class Real>
void expect_scatter_matches_gather(const Case& c) {
  using Kernel = ms::DensityKernelWarren;
  WallScene<Real> scene(c);
  auto v = scene.view();
  const int first = v.cell_start[v.frozen_part];
  const int frozen = v.n - first;
  ASSERT_GT(first, 0);
  ASSERT_GT(frozen, 0);
  std::vector<Real> frozen_rho(frozen), frozen_bvf(frozen);
  for (int i = first; i < v.n; ++i)
    ms::frozen_sums_of_particle<Real, Kernel, true>(v, i, frozen_rho.data(), frozen_bvf.data());
  v.frozen_rho = frozen_rho.data();
  v.frozen_bvf = frozen_bvf.data();

  for (int i = 0; i < v.n; ++i) ms::SumsPass<Real, Kernel, true>{}(v, i);
  const std::vector<Real> rho_gather = scene.s.rho, bvf_gather = scene.s.bvf;

  std::fill(scene.s.rho.begin(), scene.s.rho.end(), Real(-1));
  std::fill(scene.s.bvf.begin(), scene.s.bvf.end(), Real(-1));
  std::vector<unsigned long long> fixed(frozen, 0);
  const ms::SumsPass<Real, Kernel, true, ms::FrozenDensityScatter<Real>> scattering{
      {fixed.data(), first}};
  for (int i = 0; i < first; ++i) scattering(v, i);
  for (int i = first; i < v.n; ++i) ms::finish_scattered_sums<Real, true, true>(v, i, fixed.data());

  const double tolerance = sizeof(Real) == 4 ? 2e-6 : 1e-12;
  int fed = 0;  // frozen particles with mobile neighbours: the test has teeth only with many
  double worst = 0;
  for (int i = 0; i < v.n; ++i) {
    ASSERT_EQ(scene.s.bvf[i], bvf_gather[i]) << i;
    if (i < first) {
      ASSERT_EQ(scene.s.rho[i], rho_gather[i]) << i;
      continue;
    }
    const double gathered = rho_gather[i], from_mobile = gathered - frozen_rho[i - first];
    fed += from_mobile > 0.1;
    worst = std::max(worst, std::abs(scene.s.rho[i] - gathered) / (1 + gathered));
  }
  EXPECT_LE(worst, tolerance);
  EXPECT_GT(fed, frozen / 5);
  for (unsigned long long f : fixed) ASSERT_EQ(f, 0u);
}

TYPED_TEST(FrozenScatterTest, FrozenRhoAsTheGatherGivesItMobileSumsUnchanged) {
  expect_scatter_matches_gather<TypeParam>(Case{});
}

TYPED_TEST(FrozenScatterTest, HoldsOnReflectiveAxesAShortAxisAndTwoCellsPerCutoff) {
  Case c;
  c.periodic[2] = false;
  c.length[0] = 2.5;
  c.reach = 2;
  expect_scatter_matches_gather<TypeParam>(c);
}

// The fixed point: a weight rounds to the nearest 2^-44, and the sum is exact in integers.
TEST(FrozenScatter, FixedPointRoundsEachWeightToTheNearestUnit) {
  std::vector<unsigned long long> fixed(2, 0);
  const ms::FrozenDensityScatter<double> scatter{fixed.data(), 10};
  scatter(3, 1.0);  // a mobile neighbour: nothing scattered
  EXPECT_EQ(fixed[0], 0u);
  scatter(10, 1.0);
  scatter(10, 0.25);
  scatter(11, std::ldexp(1.0, -45) * 3);  // 1.5 units: rounds to 2
  EXPECT_EQ(fixed[0], (1ull << 44) + (1ull << 42));
  EXPECT_EQ(fixed[1], 2u);
}

}  // namespace
