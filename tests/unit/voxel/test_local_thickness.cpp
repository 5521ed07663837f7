// Distance transform and local thickness against exhaustive references (reference.h): random
// balls and random voxels, isotropic and anisotropic spacing (dyadic values, so both sides
// compute the same squares exactly), with and without the ridge shortcut.
#include <gtest/gtest.h>

#include <cmath>

#include "mesorock/errors.h"
#include "reference.h"
#include "test_util.h"
#include "voxel/local_thickness.h"
#include "voxel/segment.h"

namespace mesorock::voxel::test {
namespace {

const Spacing kSpacings[] = {
    {1, 1, 1, "voxel"}, {2, 1, 1, "nm"}, {1.5, 0.75, 1.25, "um"}, {0.5, 1, 2, "nm"}};

TEST(LocalThickness, SquaredDistanceMatchesExhaustiveSearch) {
  int k = 0;
  for (const Spacing& spacing : kSpacings) {
    for (std::uint64_t seed : {11u, 12u}) {
      const Volume v = k % 2 ? random_labels(Shape{9, 13, 11}, 0.7, 0.05, seed, spacing)
                             : random_balls(Shape{14, 12, 16}, 5, 1.5, 5, seed, spacing);
      ++k;
      const std::vector<double> ref = ref_squared_distance(v);
      const Volume d = squared_pore_distance(v);
      ASSERT_EQ(d.dtype(), DType::kFloat32);
      const float* got = d.data<float>();
      for (std::size_t i = 0; i < ref.size(); ++i) {
        ASSERT_NEAR(double(got[i]), ref[i], 1e-6 * std::max(1.0, ref[i]))
            << "voxel " << i << ", spacing " << spacing.str() << ", seed " << seed;
      }
    }
  }
}

TEST(LocalThickness, MatchesLargestInscribedSphereOverAllCentres) {
  int k = 0;
  for (const Spacing& spacing : kSpacings) {
    for (std::uint64_t seed : {21u, 22u, 23u}) {
      const Volume v = k % 3 == 2 ? random_labels(Shape{10, 11, 9}, 0.65, 0.0, seed, spacing)
                                  : random_balls(Shape{15, 14, 13}, 6, 1.2, 5.5, seed, spacing);
      ++k;
      const std::vector<double> ref = ref_local_thickness(v);
      for (bool ridge : {true, false}) {
        LocalThicknessOptions o;
        o.skip_contained_spheres = ridge;
        const Volume t = local_thickness(v, o);
        const float* got = t.data<float>();
        for (std::size_t i = 0; i < ref.size(); ++i) {
          ASSERT_NEAR(double(got[i]), ref[i], 1e-5 * std::max(1.0, ref[i]))
              << "voxel " << i << ", spacing " << spacing.str() << ", seed " << seed << ", ridge "
              << ridge;
        }
      }
    }
  }
}

TEST(LocalThickness, SlabOfKnownWidth) {
  // A pore slab 5 voxels thick in x between solid planes: every pore voxel's largest sphere has
  // the centre plane's distance 3 (to the walls at x = 0 and x = 6), diameter 6 voxels.
  Volume v(Shape{6, 6, 7}, DType::kUInt8, Spacing{1, 1, 0.5, "nm"});
  std::uint8_t* p = v.data<std::uint8_t>();
  for (std::int64_t i = 0; i < v.voxels(); ++i) {
    const std::int64_t x = i % 7;
    p[i] = (x == 0 || x == 6) ? 3 : 1;
  }
  const Volume t = local_thickness(v);
  for (std::int64_t i = 0; i < v.voxels(); ++i) {
    if (p[i] == 1) ASSERT_FLOAT_EQ(t.data<float>()[i], 3.0f) << i;  // 2 x 3 voxels x 0.5 nm
  }
  const SizeDistribution d = size_distribution(t, v);
  EXPECT_EQ(d.pore_voxels, 6 * 6 * 5);
  EXPECT_DOUBLE_EQ(d.max, 3.0);
  EXPECT_DOUBLE_EQ(d.mean, 3.0);
  double sum = 0;
  for (double f : d.volume_fraction) sum += f;
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(d.edges[1] - d.edges[0], 0.5);   // the smallest spacing
  EXPECT_DOUBLE_EQ(d.volume_fraction.back(), 1.0);  // 3.0 falls in the last bin
}

TEST(LocalThickness, AllPoreIsRefused) {
  Volume v(Shape{3, 3, 3}, DType::kUInt8);
  std::fill_n(v.data<std::uint8_t>(), v.voxels(), std::uint8_t(1));
  EXPECT_THROW(local_thickness(v), ConfigError);
  // No pore at all: zero everywhere, an empty distribution.
  std::fill_n(v.data<std::uint8_t>(), v.voxels(), std::uint8_t(3));
  const Volume t = local_thickness(v);
  EXPECT_EQ(size_distribution(t, v).pore_voxels, 0);
}

// The critical pore diameter: a channel 8 voxels wide along x with a neck 4 voxels wide (by
// hand: the neck's middle voxels are 2 voxel centres from the solid, so 2 x 2 = 4 voxels) passes
// spheres of 4 voxels and no wider; along y nothing spans (the channel is closed there by solid
// rows), and a solid plane across x closes it to 0. The spacing scales the answer.
TEST(LocalThickness, CriticalDiameterIsTheNeckOfAChannel) {
  for (const double dx : {1.0, 2.5}) {
    Volume v(Shape{12, 12, 20}, DType::kUInt8, Spacing{dx, dx, dx, "nm"});
    std::uint8_t* c = v.data<std::uint8_t>();
    for (std::int64_t z = 0; z < 12; ++z)
      for (std::int64_t y = 0; y < 12; ++y)
        for (std::int64_t x = 0; x < 20; ++x) {
          const bool wide = y >= 2 && y < 10 && z >= 2 && z < 10;
          const bool neck = y >= 4 && y < 8 && z >= 4 && z < 8;
          const bool in_neck_span = x >= 9 && x < 12;
          const bool pore = in_neck_span ? neck : wide;
          c[(z * 12 + y) * 20 + x] =
              static_cast<std::uint8_t>(pore ? Phase::kPore : Phase::kInorganic);
        }
    EXPECT_NEAR(critical_pore_diameter(v, 2), 4 * dx, 1e-9) << dx;
    EXPECT_EQ(critical_pore_diameter(v, 1), 0.0);
    for (std::int64_t z = 0; z < 12; ++z)
      for (std::int64_t y = 0; y < 12; ++y)
        c[(z * 12 + y) * 20 + 15] = static_cast<std::uint8_t>(Phase::kInorganic);
    EXPECT_EQ(critical_pore_diameter(v, 2), 0.0);
  }
  EXPECT_THROW(critical_pore_diameter(Volume(Shape{2, 2, 2}, DType::kUInt8), 3), ConfigError);
}

}  // namespace
}  // namespace mesorock::voxel::test
