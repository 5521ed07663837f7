// The converged continuum reference (lbm/ladder.h, docs/lbm.md): the extrapolation on known
// sequences, and the ladder on voxel geometries whose Stokes permeability is known.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "lbm/ladder.h"
#include "lbm/lattice.h"
#include "mesorock/errors.h"
#include "sim/solid_grid.h"
#include "unit/lbm/masks.h"

namespace {

namespace ml = mesorock::lbm;
namespace ms = mesorock::sim;

using mesorock::test::make_mask;

std::vector<double> sequence(const std::vector<int>& r, const std::function<double(double)>& k) {
  std::vector<double> out;
  for (const int v : r) out.push_back(k(v));
  return out;
}

// k_inf + C1/r + C2/r^2 through three rungs is exact for first order, second order and their mix;
// the power law's order is 1 and 2 for the pure ones.
TEST(LbmExtrapolate, ExactForFirstAndSecondOrderAndTheirMix) {
  const std::vector<int> r = {1, 2, 3, 4};
  const auto first = ml::extrapolate(r, sequence(r, [](double x) { return 5 + 3 / x; }));
  EXPECT_NEAR(first.k_voxel2, 5, 1e-12);
  EXPECT_NEAR(first.error_voxel2, 0, 1e-12);
  EXPECT_NEAR(first.order, 1, 1e-9);
  EXPECT_NEAR(first.order_previous, 1, 1e-9);
  EXPECT_TRUE(first.asymptotic);
  const auto second = ml::extrapolate(r, sequence(r, [](double x) { return 5 - 2 / (x * x); }));
  EXPECT_NEAR(second.k_voxel2, 5, 1e-12);
  EXPECT_NEAR(second.order, 2, 1e-9);
  EXPECT_TRUE(second.asymptotic);
  const auto mix =
      ml::extrapolate(r, sequence(r, [](double x) { return 5 + 3 / x + 2 / (x * x); }));
  EXPECT_NEAR(mix.k_voxel2, 5, 1e-12);
  EXPECT_TRUE(mix.warnings.empty()) << mix.warnings.front();
  // A third-order term is what the error sees: the two triples then disagree.
  const auto cubic =
      ml::extrapolate(r, sequence(r, [](double x) { return 5 + 3 / x + 4 / (x * x * x); }));
  EXPECT_GT(cubic.error_voxel2, 0.1);
  EXPECT_LT(std::abs(cubic.k_voxel2 - 5), std::abs(3 * cubic.error_voxel2));
}

// The independent solver's ladder on Berea 50^3 (../shared/findings/converged-reference.md):
// 1558.76, 1384.83, 1327.35, 1299.68 mD at refine 1..4. Through the last three: 2 k2 - 9 k3 + 8
// k4 = 1220.95 mD; through the first three 1213.1, so the error is 7.85 (0.64%); the power-law
// orders are 1.01 and 1.11 (first order). The findings' own limit, 4 k4 - 3 k3 = 1216.6 mD, is
// within the error (0.36%).
TEST(LbmExtrapolate, TheBereaLadderOfTheFindings) {
  const auto e = ml::extrapolate({1, 2, 3, 4}, {1558.76, 1384.83, 1327.35, 1299.68});
  EXPECT_NEAR(e.k_voxel2, 2 * 1384.83 - 9 * 1327.35 + 8 * 1299.68, 1e-9);
  EXPECT_NEAR(e.error_voxel2, std::abs(e.k_voxel2 - (0.5 * 1558.76 - 4 * 1384.83 + 4.5 * 1327.35)),
              1e-9);
  EXPECT_NEAR(e.order, 1.11, 0.01);
  EXPECT_NEAR(e.order_previous, 1.01, 0.01);
  EXPECT_TRUE(e.asymptotic);
  EXPECT_LT(std::abs(e.k_voxel2 - 1216.6), e.error_voxel2);
  EXPECT_LT(e.error_voxel2 / e.k_voxel2, 0.01);
}

TEST(LbmExtrapolate, WarnsWhereTheLadderCannotTell) {
  const auto one = ml::extrapolate({2}, {7.0});
  EXPECT_FALSE(one.extrapolated);
  EXPECT_EQ(one.k_voxel2, 7.0);
  EXPECT_TRUE(std::isnan(one.error_voxel2));
  ASSERT_FALSE(one.warnings.empty());
  const auto two = ml::extrapolate({1, 2}, {6.0, 5.5});
  EXPECT_NEAR(two.k_voxel2, 5.0, 1e-12);  // first order assumed
  EXPECT_NEAR(two.error_voxel2, 0.5, 1e-12);
  EXPECT_FALSE(two.asymptotic);
  const auto wobble = ml::extrapolate({1, 2, 3, 4}, {10.0, 9.0, 9.5, 9.2});
  EXPECT_FALSE(wobble.asymptotic);
  bool warned = false;
  for (const auto& w : wobble.warnings)
    warned = warned || w.find("asymptotic") != std::string::npos;
  EXPECT_TRUE(warned);
  EXPECT_THROW(ml::extrapolate({1, 2}, {1.0}), mesorock::ConfigError);
}

ml::LadderOptions tight(std::vector<int> refines, double tau = 0.8) {
  ml::LadderOptions o;
  o.refines = std::move(refines);
  o.base.tau = tau;
  o.base.threads = 1;
  o.base.tolerance = 1e-10;
  o.base.max_steps = 200000;
  return o;
}

// A slit of gap h in a period H, flow along x: on a lattice refined r times the node sum gives
// (h/H)(h^2 + 1/(2 r^2))/12 exactly (second order), so three rungs extrapolate to the continuum
// (h/H) h^2/12 exactly (1e-6 asked, tolerance-limited).
TEST(LbmLadder, SlitExtrapolatesToTheContinuum) {
  const ms::SolidMask m = make_mask(2, 2, 8, [](auto, auto, auto k) { return k >= 6; });
  const ml::LadderResult r = ml::lbm_ladder(m, tight({1, 2, 3}));
  ASSERT_EQ(r.rungs.size(), 3u);
  const double continuum = 0.75 * 36 / 12;
  for (const ml::Rung& g : r.rungs)
    EXPECT_NEAR(g.k_voxel2 / continuum - 1, 1 / (2 * 36.0 * g.refine * g.refine), 1e-6);
  EXPECT_NEAR(r.extrapolation.k_voxel2 / continuum - 1, 0, 1e-6);
  EXPECT_NEAR(r.extrapolation.order, 2, 0.01);
  EXPECT_TRUE(r.extrapolation.asymptotic);
}

// A square duct of side a (one solid layer between periodic neighbours): the series solution
// k_pore = a^2/12 [1 - (192 / pi^5) sum_{n odd} tanh(n pi / 2) / n^5] (e.g. White, Viscous Fluid
// Flow, eq. 3-48), Darcy over the cell k = k_pore a^2 / (a + 1)^2. The issue asks for 0.5%; one
// lattice at a = 8 is +0.7% (the midpoint rule's 1/24 voxel^2).
TEST(LbmLadder, SquareDuctWithinHalfAPercentOfTheSeries) {
  const std::int64_t a = 8;
  double series = 0;
  for (int n = 1; n < 200; n += 2) series += std::tanh(n * M_PI / 2) / std::pow(n, 5);
  const double k_pore = 64.0 / 12 * (1 - 192 / std::pow(M_PI, 5) * series);
  const double reference = k_pore * 64.0 / 81.0;
  const ms::SolidMask m =
      make_mask(2, a + 1, a + 1, [&](auto, auto j, auto k) { return j == a || k == a; });
  const ml::LadderResult r = ml::lbm_ladder(m, tight({1, 2, 3}));
  EXPECT_NEAR(r.extrapolation.k_voxel2 / reference - 1, 0, 0.005)
      << "k_inf = " << r.extrapolation.k_voxel2 << ", series " << reference;
  EXPECT_LT(r.extrapolation.error_voxel2 / reference, 0.005);
}

// Starting each rung from the previous rung's flow saves steps and changes no k beyond the
// convergence tolerance.
TEST(LbmLadder, WarmStartSavesStepsNotAccuracy) {
  const ms::SolidMask m = make_mask(12, 12, 12, [](auto i, auto j, auto k) {
    return std::hypot(i + 0.5 - 6, j + 0.5 - 6, k + 0.5 - 6) < 4.2;
  });
  ml::LadderOptions o = tight({1, 2, 3}, 1.0);
  o.base.tolerance = 1e-8;
  const ml::LadderResult warm = ml::lbm_ladder(m, o);
  o.warm_start = false;
  const ml::LadderResult cold = ml::lbm_ladder(m, o);
  std::int64_t warm_steps = 0, cold_steps = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(warm.rungs[i].k_voxel2 / cold.rungs[i].k_voxel2 - 1, 0, 1e-5) << i;
    warm_steps += warm.rungs[i].result.steps;
    cold_steps += cold.rungs[i].result.steps;
  }
  EXPECT_LT(warm_steps, cold_steps);
  EXPECT_EQ(warm.rungs[0].result.steps, cold.rungs[0].result.steps);
}

TEST(LbmLadder, RefusesBadRungs) {
  const ms::SolidMask m = make_mask(2, 2, 4, [](auto, auto, auto k) { return k >= 2; });
  EXPECT_THROW(ml::lbm_ladder(m, tight({2, 2})), mesorock::ConfigError);
  EXPECT_THROW(ml::lbm_ladder(m, tight({3, 2})), mesorock::ConfigError);
  EXPECT_THROW(ml::lbm_ladder(m, tight({1, 9})), mesorock::ConfigError);
  const ms::SolidMask wall = make_mask(4, 4, 4, [](auto i, auto, auto) { return i == 0; });
  const ml::LadderResult none = ml::lbm_ladder(wall, tight({1, 2, 3}));
  EXPECT_FALSE(none.percolates);
  EXPECT_EQ(none.rungs.size(), 1u);  // the same components on every lattice
  EXPECT_EQ(none.extrapolation.k_voxel2, 0);
}

}  // namespace
