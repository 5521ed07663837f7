// Real rock images from ../shared/data/rocks (see its README): porosities measured there with
// numpy, and format cross-checks. Each test skips with a message when the folder is absent.
#include <gtest/gtest.h>

#include <cmath>

#include "mesorock/errors.h"
#include "test_util.h"
#include "voxel/filters.h"
#include "voxel/load.h"
#include "voxel/pore_analysis.h"
#include "voxel/segment.h"

namespace mesorock::voxel::test {
namespace {

double porosity_with_map(const fs::path& file, const std::string& map, LoadOptions options = {}) {
  Volume v = load_volume(file, options);
  const Volume labels = segment_by_label_map(std::move(v), LabelMap::parse(map));
  return count_phases(labels).porosity();
}

TEST(Rocks, BereaNpzPorosity) {
  SKIP_WITHOUT_ROCKS();
  const Volume v = load_volume(rock("berea_100_to_300.npz"));
  EXPECT_EQ(v.shape(), (Shape{200, 200, 200}));
  EXPECT_EQ(v.dtype(), DType::kBool);
  // README: 0.19872 (numpy, 5 digits).
  const double phi = porosity_with_map(rock("berea_100_to_300.npz"), "true=pore,false=solid");
  EXPECT_NEAR(phi, 0.19872, 0.5e-5);
}

TEST(Rocks, BereaClustersAndPercolation) {
  SKIP_WITHOUT_ROCKS();
  // README (numpy/scipy, 6-connected): 331 pore clusters, percolating porosity 0.19774 (the
  // spanning cluster spans all three axes). scipy.ndimage.label with the full 3x3x3 structure
  // gives 262 clusters and 0.197848 for 26-connectivity (checked here the same way).
  Volume v = load_volume(rock("berea_100_to_300.npz"));
  const Volume labels =
      segment_by_label_map(std::move(v), LabelMap::parse("true=pore,false=solid"));
  const PoreRuns runs = find_pore_runs(labels);
  const double counted = double(labels.voxels());
  const PercolationSummary six = summarize_clusters(find_pore_clusters(runs));
  EXPECT_EQ(six.clusters, 331);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(double(six.spanning_voxels[std::size_t(axis)]) / counted, 0.19774, 0.5e-5)
        << axis_name(axis);
  }
  ClusterOptions all;
  all.connectivity = 26;
  const PercolationSummary c26 = summarize_clusters(find_pore_clusters(runs, all));
  EXPECT_EQ(c26.clusters, 262);
  EXPECT_NEAR(double(c26.spanning_voxels[0]) / counted, 0.197848375, 1e-9);
}

TEST(Rocks, BereaRawTwinPorosity) {
  SKIP_WITHOUT_ROCKS();
  LoadOptions o;
  o.shape = Shape{200, 200, 200};
  o.dtype = DType::kUInt8;
  const double phi =
      porosity_with_map(rock("Berea_center_cropped_200_200.raw"), "0=pore,255=solid", o);
  EXPECT_NEAR(phi, 0.19901, 0.5e-5);
  // An inverted map gives 1 - phi and a warning; a map missing 255 is refused.
  Volume v = load_volume(rock("Berea_center_cropped_200_200.raw"), o);
  const PhaseCounts inverted =
      count_phases(segment_by_label_map(std::move(v), LabelMap::parse("255=pore,0=solid")));
  EXPECT_NEAR(inverted.porosity(), 1 - 0.19901, 0.5e-5);
  EXPECT_FALSE(porosity_warning(inverted).empty());
  EXPECT_THROW(porosity_with_map(rock("Berea_center_cropped_200_200.raw"), "0=pore,1=solid", o),
               ConfigError);
}

TEST(Rocks, BereaNpzAndRawTwinAreTheSameBlockShiftedByOneSlice) {
  SKIP_WITHOUT_ROCKS();
  // README: the raw twin is the same block shifted one voxel along axis 0. Check that the
  // loaders agree on orientation: numpy finds npz[z] == (raw[z + 1] == 0) for every voxel of
  // z < 199, against 95.6% agreement unshifted.
  const Volume npz = load_volume(rock("berea_100_to_300.npz"));
  LoadOptions o;
  o.shape = Shape{200, 200, 200};
  o.dtype = DType::kUInt8;
  const Volume raw = load_volume(rock("Berea_center_cropped_200_200.raw"), o);
  auto agreement = [&](int shift_npz, int shift_raw) {
    std::int64_t same = 0, total = 0;
    for (int z = 0; z < 190; ++z) {
      const std::uint8_t* a = npz.slice<std::uint8_t>(z + shift_npz);
      const std::uint8_t* b = raw.slice<std::uint8_t>(z + shift_raw);
      for (int i = 0; i < 200 * 200; ++i, ++total) same += (a[i] != 0) == (b[i] == 0);
    }
    return double(same) / double(total);
  };
  EXPECT_EQ(agreement(0, 1), 1.0);
  EXPECT_LT(agreement(0, 0), 0.97);
  EXPECT_LT(agreement(1, 0), 0.97);
}

TEST(Rocks, MultiPageTiffDecodesToTheRawArray) {
  SKIP_WITHOUT_ROCKS();
  ReadReport report;
  const Volume tif = load_volume(rock("berea_pore.tif"), {}, &report);
  EXPECT_EQ(report.format, "tiff");
  LoadOptions o;
  o.shape = Shape{110, 110, 110};
  o.dtype = DType::kUInt8;
  const Volume raw = load_volume(rock("berea_pore.raw"), o);
  ASSERT_EQ(tif.shape(), (Shape{110, 110, 110}));
  EXPECT_TRUE(same_voxels(tif, raw));
  EXPECT_NEAR(porosity_with_map(rock("berea_pore.tif"), "0=pore,1=solid"), 0.17788, 0.5e-5);
}

TEST(Rocks, LeopardInt8NpyPorosity) {
  SKIP_WITHOUT_ROCKS();
  const Volume v = load_volume(rock("image_Leopard_slice100.npy"));
  EXPECT_EQ(v.dtype(), DType::kInt8);
  EXPECT_NEAR(porosity_with_map(rock("image_Leopard_slice100.npy"), "1=pore,0=solid"), 0.26224,
              0.6e-5);
}

TEST(Rocks, CarbonateSliceFieldOfViewFromSentinel) {
  SKIP_WITHOUT_ROCKS();
  // 35_1.tiff: 1008x980 uint16, pixels equal to 1 lie outside the circular field of view.
  Volume v = load_volume(rock("35_1.tiff"));
  ASSERT_EQ(v.shape(), (Shape{1, 1008, 980}));
  ASSERT_EQ(v.dtype(), DType::kUInt16);
  const FieldOfView fov = field_of_view_from_value(v, 1);
  // numpy on the same pixels: centroid (497.91, 504.0), equal-area radius 483.71.
  EXPECT_NEAR(fov.cx, 497.91, 0.01);
  EXPECT_NEAR(fov.cy, 504.0, 0.01);
  EXPECT_NEAR(fov.radius, 483.71, 0.01);
  // The fitted circle separates the sentinel from the rock: few pixels on the wrong side.
  std::int64_t sentinel_inside = 0, rock_outside = 0, inside = 0;
  const std::uint16_t* p = v.data<std::uint16_t>();
  for (std::int64_t y = 0; y < 1008; ++y) {
    for (std::int64_t x = 0; x < 980; ++x) {
      const bool in = fov.contains(double(x), double(y));
      inside += in;
      sentinel_inside += in && p[y * 980 + x] == 1;
      rock_outside += !in && p[y * 980 + x] != 1;
    }
  }
  EXPECT_LT(double(sentinel_inside) / double(inside), 0.005);
  EXPECT_LT(rock_outside, 0.005 * double(inside));
  // Excluding the field of view, no sentinel pixel takes part in the histogram.
  Exclusion exclusion;
  exclusion.value = 1;
  const Histogram h = histogram_of(v, exclusion, 256);
  EXPECT_GT(h.lo, 1.0);
}

}  // namespace
}  // namespace mesorock::voxel::test
