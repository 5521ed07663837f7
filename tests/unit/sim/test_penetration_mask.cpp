// The penetration mask (sim/penetration_mask.h): wherever a cell's bit is clear, phi over the
// frozen part (what the GPU's corrector before the sort computes, Parts::FrozenOnly) is at most
// phi_c, so skipping the scan there changes no decision. Checked at random points against the
// scan itself, in float and double, on periodic and reflective axes, an axis too short for the
// 3-cell stencil and 2 cells per cutoff; and the mask must leave most of the fluid clear, or it
// saves nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "sim/kernels.h"
#include "sim/penetration_mask.h"
#include "unit/sim/wall_scene.h"

namespace ms = mesorock::sim;

namespace {

using mesorock::test::Case;
using mesorock::test::WallScene;

struct Sampled {
  int points = 0, scanned = 0, past_phi_c = 0, missed = 0;
  double worst_missed_phi = 0;
};

// phi over the frozen part at random points (particle 0, a fluid one, moved there), and what the
// mask says of each.
template <class Real>
Sampled sample(WallScene<Real>& scene, int points, unsigned seed = 9) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  auto v = scene.view();
  Sampled out;
  for (int k = 0; k < points; ++k) {
    Real* p[3] = {v.x, v.y, v.z};
    for (int a = 0; a < 3; ++a)
      p[a][0] = v.box.lo[a] + static_cast<Real>(u(rng) * static_cast<double>(v.box.length[a]));
    const Real phi = ms::wall_fraction(v, 0, ms::Parts::FrozenOnly);
    const bool may = scene.mask.may_exceed(v.x[0], v.y[0], v.z[0]);
    ++out.points;
    out.scanned += may;
    if (phi > v.walls.phi_c) {
      ++out.past_phi_c;
      if (!may) {
        ++out.missed;
        out.worst_missed_phi = std::max(out.worst_missed_phi, static_cast<double>(phi));
      }
    }
  }
  return out;
}

template <class Real>
void expect_sound(const Case& c) {
  WallScene<Real> scene(c);
  ASSERT_EQ(scene.view().type[0], 0);  // particle 0 is mobile fluid (the mobile part comes first)
  const Sampled s = sample(scene, 60000);
  // The test has teeth only if some points are past phi_c (inside the wall slab and the ball).
  EXPECT_GT(s.past_phi_c, s.points / 10);
  EXPECT_EQ(s.missed, 0) << "worst phi in a clear cell: " << s.worst_missed_phi;
  // Most of the pore (z above the wall slab by more than rc, away from the ball) is clear: the
  // slab and the ball take about 45% of the box, so a mask that saved nothing would scan all.
  EXPECT_LT(s.scanned, s.points * 3 / 4);
}

template <class Real>
class PenetrationMaskTest : public ::testing::Test {};
using Reals = ::testing::Types<float, double>;
TYPED_TEST_SUITE(PenetrationMaskTest, Reals);

TYPED_TEST(PenetrationMaskTest, AClearCellNeverHidesPhiPastPhiC) {
  expect_sound<TypeParam>(Case{});
}

TYPED_TEST(PenetrationMaskTest, HoldsOnReflectiveAxesAndAShortPeriodicAxis) {
  Case c;
  c.periodic[2] = false;  // the wall slab against a reflective face
  c.length[0] = 2.5;      // 2 cells along x: the stencil takes the whole axis
  expect_sound<TypeParam>(c);
}

TYPED_TEST(PenetrationMaskTest, HoldsWithTwoCellsPerCutoff) {
  Case c;
  c.reach = 2;
  expect_sound<TypeParam>(c);
}

// A point deep in the wall is set, one more than rc from every wall particle is clear.
TEST(PenetrationMask, SetsTheWallAndClearsThePore) {
  WallScene<double> scene(Case{});
  EXPECT_TRUE(scene.mask.may_exceed(3.0, 2.5, 0.0));   // z = 0.5 before the shift: deep in the slab
  EXPECT_FALSE(scene.mask.may_exceed(0.0, 0.0, 4.5));  // 2.5 rc from the slab, 2.7 from the ball
  EXPECT_TRUE(scene.mask.may_exceed(-10, 0, 0));       // outside the grid: scanned
  EXPECT_TRUE(scene.mask.may_exceed(0, std::nan(""), 0));
}

TEST(PenetrationMask, GeometryCoversTheBoxInWholeWordsWithinItsCellCap) {
  const double lo[3] = {-1, 0, 2}, length[3] = {50, 40, 30};
  const auto fine = ms::penetration_mask_geometry<double>(lo, length, 0.125, 1e9);
  EXPECT_EQ(fine.dims[0] % 32, 0);
  EXPECT_EQ(fine.dims[1], 320);
  EXPECT_EQ(fine.dims[2], 240);
  EXPECT_GE(fine.dims[0] * fine.cell[0], 50);
  const auto capped = ms::penetration_mask_geometry<double>(lo, length, 0.125, 1e6);
  EXPECT_LE(static_cast<double>(capped.words()) * 32, 1e6);
  for (int a = 0; a < 3; ++a) EXPECT_GE(capped.dims[a] * capped.cell[a], length[a]);
  EXPECT_GT(capped.cell[0], 0.125);
}

}  // namespace
