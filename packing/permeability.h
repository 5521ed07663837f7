#pragma once
// The permeability layout: the porous block alone in a box that is periodic on every axis, for a
// body-force sweep (rockflow sweep, docs/permeability.md). No reservoirs, slabs or virtual walls.
//
// A rock image is not periodic: along the flow axis its inlet face does not match its outlet
// face, so pores would end against solid across the periodic boundary. The standard remedy is
// mirroring: the block followed by its mirror image along the flow axis (voxel n + i is voxel
// n - 1 - i), which is periodic by construction (the faces that meet at the mirror plane and
// across the box's boundary are copies of each other) at the price of a box twice as long. The
// other axes wrap as they are. `mirror = false` keeps the block as it is (for blocks made
// periodic already).
//
// Roles: three of the flooding layout's codes (flooding.h): kRoleBlockFluid for the pores' fluid,
// kRoleOrganicWall and kRoleInorganicWall for the surface walls, so one role table packs either
// layout. The wall sweep (voxel/walls.h) runs on the box padded with its periodic images by the
// wall layers, so solid voxels within the wall thickness of a pore across a periodic boundary
// become walls too; deeper solid stays empty. Optionally only the pore clusters that join the
// block's two faces normal to the flow axis are kept (the others become their host solid, as in
// the flooding layout).
//
// Coordinates: solver axes (x, y, z) = voxel axes (x, y, z); the box starts at 0 on every axis.
#include <array>

#include "packing/flooding.h"

namespace mesorock::packing {

struct PermeabilityOptions {
  int flow_axis = 0;                              // solver axis: 0 x, 1 y, 2 z
  std::array<double, 3> voxel_rc{0.5, 0.5, 0.5};  // voxel edges (x, y, z) in rc
  double wall_thickness_rc = 1.0;                 // surface-wall thickness, >= 1 (the cutoff)
  bool connected_only = true;  // keep only pore clusters joining the faces along the flow axis
  int connectivity = 6;        // 6 or 26, for the clusters
  bool mirror = true;          // the block and its mirror image along the flow axis
};

// codes: the box's voxels (the block, mirrored when `mirrored`); box: periodic on every axis,
// from 0. block_extent and the voxel counts are the block's (one copy).
struct PermeabilityLayout : VoxelLayout {
  bool mirrored = false;
};

// `labels`: uint8 phase codes (voxel/segment.h) of the block, voxel edges in options.voxel_rc.
// Taken by value (std::move it in). Throws ConfigError for bad options, a box edge under 2 rc
// (the shortest periodic edge the solver accepts), or when no pore cluster joins the faces.
PermeabilityLayout build_permeability_layout(voxel::Volume labels,
                                             const PermeabilityOptions& options);

}  // namespace mesorock::packing
