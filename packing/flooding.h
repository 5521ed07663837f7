#pragma once
// The flooding set-up of the 2020 paper's miniature test, as voxel roles for pack_voxels: a
// porous block (phase labels) saturated with source fluid; along the flow axis, before the block,
// a pushing slab and a reservoir of working fluid, and after it a reservoir of source fluid, a
// back-pressure slab and empty room for the slab to move into:
//
//   | push slab | working fluid | block (source in the pores, walls) | source fluid | back slab |
//   room | ^ box face               flow axis = 0 (the block's inlet face) box face ^
//
// Only the surface-wall voxels of the block get wall particles (voxel/walls.h): solid voxels
// within the wall thickness of a pore voxel or of a reservoir (so the block's inlet and outlet
// faces are sealed too; deeper solid stays empty). Each solid phase is its own wall type, so
// organic and inorganic walls can wet differently. Optionally only the pore clusters that connect
// the inlet face to the outlet face are kept: other pores become their host solid (organic_pore
// -> organic, pore -> inorganic) before the wall sweep, so they cost no particles.
//
// Coordinates: solver axes (x, y, z) = voxel axes (x, y, z); the block starts at 0 on every axis.
// The paper's test flows towards -x with the working fluid at the high end; this layout is its
// mirror image (flow towards +axis), which changes nothing physical.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/model.h"
#include "voxel/volume.h"

namespace mesorock::packing {

// The role codes of the layout (1-based, as pack_voxels expects; 0 = nothing).
enum FloodingRole : std::uint8_t {
  kRoleBlockFluid = 1,     // source fluid in the block's pores
  kRoleInletFluid = 2,     // working fluid in the inlet reservoir
  kRoleOutletFluid = 3,    // source fluid in the outlet reservoir
  kRoleOrganicWall = 4,    // surface-wall voxels of organic matter
  kRoleInorganicWall = 5,  // surface-wall voxels of the inorganic matrix
  kRolePushSlab = 6,
  kRoleBackSlab = 7,
};
constexpr int kFloodingRoles = 7;
const char* flooding_role_name(int role);  // "source fluid in the block", ...

struct FloodingOptions {
  int flow_axis = 0;                              // solver axis: 0 x, 1 y, 2 z
  std::array<double, 3> voxel_rc{0.5, 0.5, 0.5};  // voxel edges (x, y, z) in rc
  double wall_thickness_rc = 1.0;                 // surface-wall thickness, >= 1 (the cutoff)
  bool connected_only = true;  // keep only pore clusters joining inlet and outlet faces
  int connectivity = 6;        // 6 or 26, for the clusters
  double inlet_rc = 4.0;       // working-fluid reservoir length
  double outlet_rc = 4.0;      // source-fluid reservoir length
  double slab_rc = 2.0;        // slab thickness (fluid passes through a 1 rc slab of tiles)
  double room_rc = -1;         // empty room behind the back slab; < 0: the block's pore
                               // volume over the cross-section, plus 1 rc
};

// What a layout hands to the packer (role codes over the box's voxels and where they lie) and to
// rockprep run's records (the block's voxel counts); the flooding and permeability layouts
// (permeability.h) add their own geometry.
struct VoxelLayout {
  voxel::Volume codes;  // uint8 role codes (z, y, x) over the box
  std::array<double, 3> voxel_rc{};
  std::array<double, 3> origin{};  // (x, y, z) of voxel (0, 0, 0)'s corner
  sim::BoxSpec box;
  int flow_axis = 0;
  std::array<double, 3> block_extent{};  // the block's edges (x, y, z), rc
  // Counts (voxels).
  std::int64_t block_voxels = 0, pore_voxels = 0, pore_voxels_dropped = 0, solid_voxels = 0;
  std::int64_t spanning_clusters = 0, clusters = 0;
  std::array<std::int64_t, kFloodingRoles + 1> role_voxels{};  // by role code
  std::array<int, 3> wall_layers_zyx{};
  bool has_role(int role) const { return role_voxels[static_cast<std::size_t>(role)] > 0; }
};

// codes: the block extended along the flow axis; box: all faces reflective.
struct FloodingLayout : VoxelLayout {
  // Along the flow axis (rc): the slabs, reservoirs and block.
  double push_lo = 0, push_hi = 0, inlet_lo = 0, block_lo = 0, block_hi = 0, outlet_hi = 0,
         back_lo = 0, back_hi = 0;
};

// What both layouts check first (`what` names the layout in the ConfigError): uint8 labels of
// known phase codes, a flow axis x, y or z, positive finite voxel edges.
void check_layout_inputs(const voxel::Volume& labels, int flow_axis,
                         const std::array<double, 3>& voxel_rc, const std::string& what);
// With connected_only, drops the pore clusters that do not join both block faces along the flow
// axis (ConfigError, naming `faces`, when none does); then counts pore and solid voxels into L.
void keep_spanning_pores_and_count(voxel::Volume& labels, int flow_axis, bool connected_only,
                                   int connectivity, const std::string& what,
                                   const std::string& faces, VoxelLayout& L);

// The solid of a layout as the solver's voxel mask (sim/solid_grid.h, written to solid.h5 beside
// the particles): the wall voxels, and the empty voxels (code 0) whose position along the flow
// axis lies in [block_lo, block_hi) rc: the grains' interiors. Empty room outside the block (behind
// a slab) stays pore. Same voxels, origin and edges as L.codes.
sim::SolidMask solid_mask_of(const VoxelLayout& L, double block_lo, double block_hi);

// `labels`: uint8 phase codes (voxel/segment.h) of the block, voxel edges in options.voxel_rc.
// Taken by value (std::move it in), so it is freed as soon as it is copied into the extended
// volume. Throws ConfigError for bad options or when no pore cluster joins the faces.
FloodingLayout build_flooding_layout(voxel::Volume labels, const FloodingOptions& options);

// Marks as solid the pore voxels of clusters that do not span volume axis `axis_zyx` (their host
// phase: organic_pore -> organic, pore -> inorganic). Returns the pore voxels changed; the
// cluster counts go to *clusters and *spanning when given.
std::int64_t drop_unconnected_pores(voxel::Volume& labels, int axis_zyx, int connectivity,
                                    std::int64_t* clusters = nullptr,
                                    std::int64_t* spanning = nullptr);

}  // namespace mesorock::packing
