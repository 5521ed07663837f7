// The synthetic shale generator: reproducible, fractions as asked, pores where they should be.
#include <gtest/gtest.h>

#include <cmath>

#include "mesorock/errors.h"
#include "test_util.h"
#include "voxel/synth.h"

namespace mesorock::voxel::test {
namespace {

ShaleOptions small() {
  ShaleOptions o;
  o.shape = {48, 64, 64};
  o.blob_radius = 8;
  return o;
}

TEST(Synth, SameSeedSameBytesOtherSeedOtherBytes) {
  const ShaleSample a = make_shale(small());
  const ShaleSample b = make_shale(small());
  EXPECT_TRUE(same_voxels(a.grey, b.grey));
  EXPECT_TRUE(same_voxels(a.truth, b.truth));
  ShaleOptions o = small();
  o.seed = 2;
  EXPECT_FALSE(same_voxels(a.grey, make_shale(o).grey));
  // A pinned value: the generator's output must not drift silently between versions.
  EXPECT_EQ(mix64(0), 0xe220a8397b1dcdafull);
}

TEST(Synth, FractionsMatchTheRequest) {
  ShaleOptions o = small();
  o.porosity = 0.12;
  o.organic_fraction = 0.3;
  o.matrix_pore_share = 0.25;
  const ShaleSample s = make_shale(o);
  const PhaseCounts& c = s.truth_counts;
  EXPECT_NEAR(c.porosity(), 0.12, 0.01);
  EXPECT_NEAR(c.fraction(Phase::kPore), 0.03, 0.005);
  EXPECT_NEAR(c.fraction(Phase::kOrganicPore), 0.09, 0.01);
  EXPECT_NEAR(c.fraction(Phase::kOrganic) + c.fraction(Phase::kOrganicPore), 0.3, 0.01);
  EXPECT_EQ(c.voxels[0], 0);
}

TEST(Synth, GreyLevelsFollowThePhasesAndNoiseLevel) {
  ShaleOptions o = small();
  o.noise = 10;
  const ShaleSample s = make_shale(o);
  double sum[5] = {0}, sum2[5] = {0}, n[5] = {0};
  for (std::int64_t i = 0; i < s.grey.voxels(); ++i) {
    const int c = s.truth.data<std::uint8_t>()[i];
    const double g = s.grey.data<std::uint8_t>()[i];
    sum[c] += g;
    sum2[c] += g * g;
    n[c] += 1;
  }
  const double expected_mean[5] = {0, 40, 100, 180, 40};
  for (int c = 1; c < 5; ++c) {
    const double mean = sum[c] / n[c];
    const double sd = std::sqrt(sum2[c] / n[c] - mean * mean);
    EXPECT_NEAR(mean, expected_mean[c], 0.5) << c;
    EXPECT_NEAR(sd, 10.0, 0.3) << c;  // rounding to integers adds ~1/12 variance
  }
}

TEST(Synth, OrganicPoresLieInOrganicMatterAndAnisotropyShapesSpheres) {
  ShaleOptions o = small();
  o.matrix_pore_share = 0;
  const ShaleSample s = make_shale(o);
  EXPECT_EQ(s.truth_counts.voxels[1], 0);  // no matrix pores asked for
  // Pores are carved out of organic matter only: the organic blobs are placed first from the
  // same random stream, so organic + organic_pore here equals organic without any pores.
  ShaleOptions no_pores = o;
  no_pores.porosity = 0;
  const ShaleSample bare = make_shale(no_pores);
  const Shape sh = s.truth.shape();
  const std::uint8_t* t = s.truth.data<std::uint8_t>();
  const std::uint8_t* b = bare.truth.data<std::uint8_t>();
  std::int64_t mismatches = 0;
  for (std::int64_t i = 0; i < sh.voxels(); ++i)
    mismatches += (t[i] == 2 || t[i] == 4) != (b[i] == 2);
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(s.truth_counts.voxels[4], 0);
  // With dz = 2 dx, spheres span about half as many slices as columns: count the organic run
  // lengths along x and along z.
  auto mean_run = [&](std::int64_t stride, std::int64_t count, std::int64_t lines) {
    double runs = 0, voxels = 0;
    for (std::int64_t line = 0; line < lines; ++line) {
      bool in = false;
      for (std::int64_t k = 0; k < count; ++k) {
        std::int64_t i;
        if (stride == 1) {
          i = line * count + k;
        } else {
          i = k * stride + line;
        }
        const bool organic = t[i] == 2 || t[i] == 4;
        voxels += organic;
        runs += organic && !in;
        in = organic;
      }
    }
    return voxels / runs;
  };
  const double along_x = mean_run(1, sh.nx, sh.nz * sh.ny);
  const double along_z = mean_run(sh.slice_voxels(), sh.nz, sh.slice_voxels());
  EXPECT_NEAR(along_x / along_z, 2.0, 0.4);
}

TEST(Synth, ImpossibleRequestsAreRefused) {
  ShaleOptions o = small();
  o.porosity = 0.5;
  o.organic_fraction = 0.1;
  EXPECT_THROW(make_shale(o), ConfigError);
  o = small();
  o.dtype = DType::kFloat32;
  EXPECT_THROW(make_shale(o), ConfigError);
}

}  // namespace
}  // namespace mesorock::voxel::test
