// OpenVDB phase grids: every voxel's phase survives, spacing is in the transform, files reopen.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>

#include "mesorock/errors.h"
#include "test_util.h"
#include "voxel/phase_grids.h"
#include "voxel/segment.h"

namespace mesorock::voxel::test {
namespace {

// Labels with uniform 8^3 blocks (tiles), mixed blocks (leaves), outside voxels, and a shape
// that is not a multiple of 8.
Volume sample_labels() {
  Volume v(Shape{19, 21, 35}, DType::kUInt8, Spacing{5, 2.5, 2.5, "nm"});
  std::uint8_t* p = v.data<std::uint8_t>();
  for (std::int64_t z = 0; z < 19; ++z)
    for (std::int64_t y = 0; y < 21; ++y)
      for (std::int64_t x = 0; x < 35; ++x) {
        std::uint8_t c = 3;
        if (x >= 16) c = 2;
        if ((x - 25) * (x - 25) + (y - 10) * (y - 10) + (z - 9) * (z - 9) < 20) c = 4;
        if (x < 8 && y < 8 && z >= 8 && z < 16) c = 1;  // a full uniform pore block
        if (x == 34 && y == 20) c = 0;                  // an outside column
        p[(z * 21 + y) * 35 + x] = c;
      }
  return v;
}

// Checks the label grid of `grids` (the last one, named "labels") voxel by voxel.
template <class GridT>
void expect_label_grid(const openvdb::GridPtrVec& grids, const Volume& labels) {
  ASSERT_FALSE(grids.empty());
  ASSERT_EQ(grids.back()->getName(), "labels");
  auto label_grid = openvdb::gridPtrCast<GridT>(grids.back());
  ASSERT_TRUE(label_grid) << grids.back()->type();
  EXPECT_EQ(label_grid->activeVoxelCount(), openvdb::Index64(count_phases(labels).counted()));
  auto accessor = label_grid->getConstAccessor();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  for (int z = 0; z < 19; ++z)
    for (int y = 0; y < 21; ++y)
      for (int x = 0; x < 35; ++x) {
        const openvdb::Coord ijk(x, y, z);
        const int code = p[(z * 21 + y) * 35 + x];
        ASSERT_EQ(int(accessor.getValue(ijk)), code) << x << "," << y << "," << z;
        ASSERT_EQ(accessor.isValueOn(ijk), code != 0);
      }
  EXPECT_FALSE(accessor.isValueOn(openvdb::Coord(35, 0, 0)));  // beyond the volume
  const openvdb::Vec3d voxel = label_grid->transform().voxelSize();
  EXPECT_DOUBLE_EQ(voxel.x(), 2.5);
  EXPECT_DOUBLE_EQ(voxel.y(), 2.5);
  EXPECT_DOUBLE_EQ(voxel.z(), 5.0);
  const openvdb::Vec3d world = label_grid->transform().indexToWorld(openvdb::Coord(2, 3, 4));
  EXPECT_DOUBLE_EQ(world.z(), 20.0);
}

TEST(PhaseGrids, EveryVoxelKeepsItsPhase) {
  const Volume labels = sample_labels();
  const PhaseCounts counts = count_phases(labels);
  const openvdb::GridPtrVec grids = build_phase_grids(labels);
  ASSERT_EQ(grids.size(), 5u);  // pore, organic, inorganic, organic_pore, labels
  for (const auto& g : grids) {
    if (g->getName() == "labels") continue;
    auto mask = openvdb::gridPtrCast<openvdb::MaskGrid>(g);
    ASSERT_TRUE(mask) << g->getName();
    const Phase phase = parse_phase(g->getName());
    EXPECT_EQ(mask->activeVoxelCount(),
              openvdb::Index64(counts.voxels[static_cast<std::size_t>(phase)]))
        << g->getName();
    EXPECT_EQ(mask->metaValue<openvdb::Int32>("phase_code"), static_cast<int>(phase));
  }
  // The default label grid holds one byte per voxel; int32 is the standard OpenVDB type.
  expect_label_grid<UInt8Grid>(grids, labels);
  PhaseGridOptions options;
  options.label_grid = LabelGridType::kInt32;
  expect_label_grid<openvdb::Int32Grid>(build_phase_grids(labels, options), labels);
  options.label_grid = LabelGridType::kNone;
  EXPECT_EQ(build_phase_grids(labels, options).size(), 4u);
  options.phase_masks = false;
  options.label_grid = LabelGridType::kUInt8;
  EXPECT_EQ(build_phase_grids(labels, options).size(), 1u);
}

TEST(PhaseGrids, Uint8LabelGridCostsAQuarterOfInt32) {
  const Volume labels = sample_labels();
  PhaseGridOptions options;
  options.phase_masks = false;
  const auto narrow = openvdb::gridPtrCast<UInt8Grid>(build_phase_grids(labels, options).back());
  options.label_grid = LabelGridType::kInt32;
  const auto wide =
      openvdb::gridPtrCast<openvdb::Int32Grid>(build_phase_grids(labels, options).back());
  ASSERT_TRUE(narrow && wide);
  EXPECT_EQ(narrow->activeVoxelCount(), wide->activeVoxelCount());
  EXPECT_EQ(narrow->tree().leafCount(), wide->tree().leafCount());
  // Per mixed block: 512 bytes and the leaf's fixed overhead against 2048 and the same overhead
  // (a volume this small is dominated by the internal nodes, so leaves are compared).
  std::size_t narrow_bytes = 0, wide_bytes = 0;
  for (auto it = narrow->tree().cbeginLeaf(); it; ++it) narrow_bytes += it->memUsage();
  for (auto it = wide->tree().cbeginLeaf(); it; ++it) wide_bytes += it->memUsage();
  EXPECT_LT(double(narrow_bytes), 0.3 * double(wide_bytes));
  EXPECT_EQ(parse_label_grid_type("uint8"), LabelGridType::kUInt8);
  EXPECT_THROW(parse_label_grid_type("int8"), ConfigError);
}

TEST(PhaseGrids, WriteAndReopenWithMetadata) {
  TempDir tmp;
  const Volume labels = sample_labels();
  write_vdb(tmp / "phases.vdb", build_phase_grids(labels), {{"source", "test"}}, "phases.vdb");
  initialize_openvdb();
  openvdb::io::File file((tmp / "phases.vdb").string());
  file.open();
  EXPECT_EQ(file.getMetadata()->metaValue<std::string>("source"), "test");
  auto pore = openvdb::gridPtrCast<openvdb::MaskGrid>(file.readGrid("pore"));
  ASSERT_TRUE(pore);
  EXPECT_EQ(pore->activeVoxelCount(), openvdb::Index64(count_phases(labels).voxels[1]));
  EXPECT_EQ(pore->metaValue<std::string>("unit"), "nm");
  auto grid = openvdb::gridPtrCast<UInt8Grid>(file.readGrid("labels"));
  ASSERT_TRUE(grid);
  EXPECT_EQ(grid->tree().getValue(openvdb::Coord(25, 10, 9)), 4);
  EXPECT_EQ(grid->type(), "Tree_uint8_5_4_3");
  file.close();
}

}  // namespace
}  // namespace mesorock::voxel::test
