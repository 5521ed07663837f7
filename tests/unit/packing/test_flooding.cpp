// The flooding layout: connected pores only, surface walls (including the block's faces against
// the reservoirs), reservoirs and slabs along the flow axis, the box; and the scene written for
// it, read back by the scene reader.
#include <gtest/gtest.h>

#include <cmath>

#include "mesorock/errors.h"
#include "packing/flooding.h"
#include "pipeline/scene.h"
#include "voxel/segment.h"

namespace mesorock::packing {
namespace {

constexpr std::uint8_t kPore = 1, kOrganic = 2, kInorganic = 3, kOrganicPore = 4;

// 10 x 12 x 16 voxels (z, y, x) of inorganic matrix with an organic lump; a straight channel
// along x (4 x 4 voxels) through it, and a pore in the organic lump that joins no faces along x.
voxel::Volume block() {
  voxel::Volume v(voxel::Shape{10, 12, 16}, voxel::DType::kUInt8);
  std::uint8_t* p = v.data<std::uint8_t>();
  for (std::int64_t z = 0; z < 10; ++z)
    for (std::int64_t y = 0; y < 12; ++y)
      for (std::int64_t x = 0; x < 16; ++x) {
        std::uint8_t c = kInorganic;
        if (z >= 6 && y >= 6) c = kOrganic;
        if (z >= 3 && z < 7 && y >= 4 && y < 8) c = kPore;
        if (z == 9 && y == 11 && x >= 6 && x < 9) c = kOrganicPore;  // isolated, in organic
        p[(z * 12 + y) * 16 + x] = c;
      }
  return v;
}

std::uint8_t at(const FloodingLayout& L, std::int64_t z, std::int64_t y, std::int64_t x) {
  const voxel::Shape s = L.codes.shape();
  return L.codes.data<std::uint8_t>()[(z * s.ny + y) * s.nx + x];
}

TEST(Flooding, LayoutAlongX) {
  FloodingOptions o;
  o.flow_axis = 0;
  o.voxel_rc = {0.5, 0.5, 0.5};
  o.inlet_rc = 2;
  o.outlet_rc = 1.5;
  o.slab_rc = 1;
  o.room_rc = 2;
  const FloodingLayout L = build_flooding_layout(block(), o);
  // 2 slab + 4 inlet voxels before the block, 3 outlet + 2 slab + 4 room after it.
  EXPECT_EQ(L.codes.shape(), (voxel::Shape{10, 12, 6 + 16 + 9}));
  EXPECT_EQ(L.wall_layers_zyx, (std::array<int, 3>{2, 2, 2}));
  EXPECT_DOUBLE_EQ(L.box.lo[0], -3.0);
  EXPECT_DOUBLE_EQ(L.box.hi[0], 12.5);
  EXPECT_DOUBLE_EQ(L.box.hi[1], 6.0);
  EXPECT_DOUBLE_EQ(L.box.hi[2], 5.0);
  EXPECT_FALSE(L.box.periodic[0] || L.box.periodic[1] || L.box.periodic[2]);
  EXPECT_DOUBLE_EQ(L.push_lo, -3.0);
  EXPECT_DOUBLE_EQ(L.push_hi, -2.0);
  EXPECT_DOUBLE_EQ(L.block_lo, 0.0);
  EXPECT_DOUBLE_EQ(L.block_hi, 8.0);
  EXPECT_DOUBLE_EQ(L.outlet_hi, 9.5);
  EXPECT_DOUBLE_EQ(L.back_hi, 10.5);
  // The isolated pore is not connected: it becomes organic.
  EXPECT_EQ(L.clusters, 2);
  EXPECT_EQ(L.spanning_clusters, 1);
  EXPECT_EQ(L.pore_voxels_dropped, 3);
  EXPECT_EQ(L.pore_voxels, 4 * 4 * 16);
  EXPECT_EQ(L.role_voxels[kRoleBlockFluid], 4 * 4 * 16);
  EXPECT_EQ(L.role_voxels[kRoleInletFluid], 10 * 12 * 4);
  EXPECT_EQ(L.role_voxels[kRoleOutletFluid], 10 * 12 * 3);
  EXPECT_EQ(L.role_voxels[kRolePushSlab], 10 * 12 * 2);
  EXPECT_EQ(L.role_voxels[kRoleBackSlab], 10 * 12 * 2);
  // Slices along x: slabs, reservoirs, block.
  EXPECT_EQ(at(L, 0, 0, 0), kRolePushSlab);
  EXPECT_EQ(at(L, 0, 0, 2), kRoleInletFluid);
  EXPECT_EQ(at(L, 5, 5, 6 + 8), kRoleBlockFluid);
  EXPECT_EQ(at(L, 0, 0, 22), kRoleOutletFluid);
  EXPECT_EQ(at(L, 0, 0, 25), kRoleBackSlab);
  EXPECT_EQ(at(L, 0, 0, 27), 0);
  // Walls: the block's face slices against the reservoirs are wall (2 voxels deep), the solid
  // within 2 voxels of the channel is wall, deeper solid is empty; the organic lump's wall is
  // organic; the dropped pore's voxels are deep solid now.
  for (std::int64_t x : {6, 7, 20, 21}) EXPECT_EQ(at(L, 0, 0, x), kRoleInorganicWall) << x;
  EXPECT_EQ(at(L, 0, 0, 8), 0);
  EXPECT_EQ(at(L, 1, 5, 12), kRoleInorganicWall);  // 2 below the channel
  EXPECT_EQ(at(L, 0, 5, 12), 0);                   // 3 below: deep
  EXPECT_EQ(at(L, 7, 8, 12), kRoleOrganicWall);    // organic next to the channel
  EXPECT_EQ(at(L, 9, 11, 6 + 7), 0);               // the isolated pore, now organic, deep
  std::int64_t walls = 0;
  for (std::int64_t i = 0; i < L.codes.voxels(); ++i) {
    const std::uint8_t c = L.codes.data<std::uint8_t>()[i];
    walls += c == kRoleOrganicWall || c == kRoleInorganicWall;
  }
  EXPECT_EQ(walls, L.role_voxels[kRoleOrganicWall] + L.role_voxels[kRoleInorganicWall]);
  EXPECT_GT(L.role_voxels[kRoleOrganicWall], 0);
}

TEST(Flooding, OtherAxisAndEveryPore) {
  FloodingOptions o;
  o.flow_axis = 2;  // z: the channel does not span it
  o.voxel_rc = {0.5, 0.5, 0.5};
  EXPECT_THROW(build_flooding_layout(block(), o), ConfigError);
  o.connected_only = false;
  const FloodingLayout L = build_flooding_layout(block(), o);
  EXPECT_EQ(L.pore_voxels_dropped, 0);
  EXPECT_EQ(L.role_voxels[kRoleBlockFluid], 4 * 4 * 16 + 3);
  EXPECT_EQ(L.flow_axis, 2);
  EXPECT_DOUBLE_EQ(L.block_hi, 5.0);  // 10 voxels along z
  EXPECT_LT(L.box.lo[2], 0.0);
  EXPECT_DOUBLE_EQ(L.box.lo[0], 0.0);
  // Default room: the pore volume over the cross-section plus 1 rc.
  const double pore_rc3 = (4 * 4 * 16 + 3) * 0.125;
  const double room = pore_rc3 / (8.0 * 6.0) + 1;
  EXPECT_NEAR(L.box.hi[2] - L.back_hi, std::ceil(room / 0.5 - 1e-9) * 0.5, 1e-12);
}

TEST(Flooding, RejectsBadInput) {
  FloodingOptions o;
  voxel::Volume bad = block();
  bad.data<std::uint8_t>()[5] = 9;
  EXPECT_THROW(build_flooding_layout(std::move(bad), o), ConfigError);
  o.wall_thickness_rc = 0.5;  // below the cutoff
  EXPECT_THROW(build_flooding_layout(block(), o), ConfigError);
  o = FloodingOptions{};
  o.inlet_rc = -1;
  EXPECT_THROW(build_flooding_layout(block(), o), ConfigError);
}

}  // namespace
}  // namespace mesorock::packing
