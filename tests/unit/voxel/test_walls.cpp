// The surface-wall sweep against a brute-force box search (reference.h), single-axis dilation,
// the length scale, wall layers and the particle estimate.
#include <gtest/gtest.h>

#include <openvdb/tools/Morphology.h>

#include "mesorock/errors.h"
#include "reference.h"
#include "test_util.h"
#include "voxel/phase_grids.h"
#include "voxel/walls.h"

namespace mesorock::voxel::test {
namespace {

// Compares the sweep with the reference, voxel by voxel and phase by phase.
void expect_walls_match(const Volume& labels, const std::array<int, 3>& layers) {
  PhaseGridOptions grid_options;
  grid_options.label_grid = LabelGridType::kNone;
  WallOptions options;
  options.layers = layers;
  const WallSweep sweep = sweep_walls(build_phase_grids(labels, grid_options), options);
  const std::vector<char> ref = ref_walls(labels, layers);
  const Shape s = labels.shape();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  std::array<std::int64_t, 5> ref_count{};
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (ref[i]) ++ref_count[p[i]];
  }
  EXPECT_EQ(sweep.voxels, ref_count);
  std::int64_t total = 0;
  for (const auto& g : sweep.walls) {
    auto mask = openvdb::gridPtrCast<openvdb::MaskGrid>(g);
    ASSERT_TRUE(mask);
    const std::uint8_t code =
        static_cast<std::uint8_t>(mask->metaValue<openvdb::Int32>("phase_code"));
    for (auto it = mask->cbeginValueOn(); it; ++it) {
      ASSERT_TRUE(it.isVoxelValue());
      const openvdb::Coord c = it.getCoord();
      ASSERT_TRUE(c.x() >= 0 && c.y() >= 0 && c.z() >= 0 && c.x() < s.nx && c.y() < s.ny &&
                  c.z() < s.nz);
      const std::size_t i = std::size_t((std::int64_t(c.z()) * s.ny + c.y()) * s.nx + c.x());
      ASSERT_TRUE(ref[i]) << c;
      ASSERT_EQ(p[i], code) << c;
      ++total;
    }
  }
  EXPECT_EQ(total, sweep.total());
}

TEST(Walls, SweepMatchesBoxSearchOnRandomVolumes) {
  const std::array<int, 3> layer_sets[] = {{1, 1, 1}, {2, 2, 2}, {1, 2, 3}, {3, 1, 2}, {2, 1, 1}};
  int k = 0;
  for (const auto& layers : layer_sets) {
    for (std::uint64_t seed : {5u, 6u}) {
      SCOPED_TRACE("layers " + std::to_string(layers[0]) + "," + std::to_string(layers[1]) + "," +
                   std::to_string(layers[2]) + " seed " + std::to_string(seed));
      // Sparse pores in solid, and big pores with large uniform (tiled) regions.
      expect_walls_match(random_labels(Shape{19, 21, 23}, 0.03, 0.05, seed + 100 * k), layers);
      expect_walls_match(random_balls(Shape{26, 30, 28}, 4, 5, 11, seed + 100 * k), layers);
      ++k;
    }
  }
}

TEST(Walls, DilationAlongOneAxis) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int steps : {1, 3, 9}) {
      openvdb::MaskTree tree;
      const openvdb::Coord seeds[] = {{0, 0, 0}, {7, 7, 7}, {-9, 20, 3}, {15, -1, 8}};
      for (const auto& c : seeds) tree.setValueOn(c);
      tree.addTile(1, openvdb::Coord(64, 64, 64), true, true);  // a tile, voxelized first
      dilate_along_axis(tree, axis, steps);
      // Expected: each seed and each tile voxel extended by `steps` along the axis.
      openvdb::MaskTree expected;
      const int coord_axis = 2 - axis;
      for (const auto& c : seeds) {
        for (int d = -steps; d <= steps; ++d) {
          openvdb::Coord e = c;
          e[coord_axis] += d;
          expected.setValueOn(e);
        }
      }
      for (int x = 64; x < 72; ++x)
        for (int y = 64; y < 72; ++y)
          for (int z = 64; z < 72; ++z)
            for (int d = -steps; d <= steps; ++d) {
              openvdb::Coord e(x, y, z);
              e[coord_axis] += d;
              expected.setValueOn(e);
            }
      EXPECT_EQ(tree.activeVoxelCount(), expected.activeVoxelCount())
          << "axis " << axis << " steps " << steps;
      openvdb::MaskTree diff(expected);
      diff.topologyDifference(tree);
      EXPECT_EQ(diff.activeVoxelCount(), 0u);
    }
  }
  openvdb::MaskTree t;
  EXPECT_THROW(dilate_along_axis(t, 3, 1), ConfigError);
}

TEST(Walls, LengthScaleAndLayers) {
  const Spacing fib{5, 2.5, 2.5, "nm"};
  LengthScale s;
  EXPECT_THROW(voxel_size_rc(s, fib), ConfigError);  // missing
  s.nm_per_rc = 5;
  auto h = voxel_size_rc(s, fib);
  EXPECT_DOUBLE_EQ(h[0], 1.0);
  EXPECT_DOUBLE_EQ(h[2], 0.5);
  EXPECT_EQ(wall_layers(1.0, h), (std::array<int, 3>{1, 2, 2}));
  EXPECT_EQ(wall_layers(1.2, h), (std::array<int, 3>{2, 3, 3}));
  EXPECT_THROW(wall_layers(0.8, h), ConfigError);  // below the cutoff
  s.rc_per_voxel = 0.1;
  EXPECT_THROW(voxel_size_rc(s, fib), ConfigError);  // both given
  s.nm_per_rc = 0;
  h = voxel_size_rc(s, fib);  // anisotropy kept: z voxels twice as long
  EXPECT_DOUBLE_EQ(h[0], 0.2);
  EXPECT_DOUBLE_EQ(h[2], 0.1);
  EXPECT_EQ(wall_layers(1.0, h), (std::array<int, 3>{5, 10, 10}));  // no 11 from rounding
  LengthScale um;
  um.nm_per_rc = 100;
  EXPECT_DOUBLE_EQ(voxel_size_rc(um, Spacing{5.345, 5.345, 5.345, "um"})[1], 53.45);
  EXPECT_THROW(voxel_size_rc(um, Spacing{}), ConfigError);  // no physical unit
  EXPECT_THROW(voxel_size_rc(um, Spacing{1, 1, 1, "furlong"}), ConfigError);
}

TEST(Walls, ParticleEstimateFormulaAndLimit) {
  // A 4x4x4 pore cube in solid, 1 rc voxels, 1 layer: 96 faces; fluid 64 rc^3.
  Volume v(Shape{8, 8, 8}, DType::kUInt8);
  std::uint8_t* p = v.data<std::uint8_t>();
  std::fill_n(p, v.voxels(), std::uint8_t(3));
  for (int z = 2; z < 6; ++z)
    for (int y = 2; y < 6; ++y)
      for (int x = 2; x < 6; ++x) p[(z * 8 + y) * 8 + x] = 1;
  const PoreStatistics stats = measure_pores(v);
  ParticleEstimateOptions o;
  const ParticleEstimate e = estimate_particles(stats, {1, 1, 1}, {1, 1, 1}, o);
  EXPECT_DOUBLE_EQ(e.pore_volume_rc3, 64);
  EXPECT_DOUBLE_EQ(e.wall_volume_rc3, 96);
  EXPECT_DOUBLE_EQ(e.fluid_particles, std::ceil(6.88 * 64));
  EXPECT_DOUBLE_EQ(e.wall_particles, std::ceil(6.88 * 96));
  EXPECT_DOUBLE_EQ(e.bytes, e.total() * 250);
  // The sweep counts the 6x6x6 shell minus the cube (with its edges and corners): 152.
  const ParticleEstimate c = count_particles(64, 6 * 6 * 6 - 64, {1, 1, 1}, o);
  EXPECT_DOUBLE_EQ(c.wall_volume_rc3, 152);
  ASSERT_DOUBLE_EQ(e.total(), 441 + 661);
  o.max_particles = 1101;
  EXPECT_THROW(check_particle_limit(e, o), LimitError);
  o.max_particles = 1102;
  EXPECT_NO_THROW(check_particle_limit(e, o));
}

}  // namespace
}  // namespace mesorock::voxel::test
