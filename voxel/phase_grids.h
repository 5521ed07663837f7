#pragma once
// Phase grids in OpenVDB: one sparse mask per phase (openvdb::MaskGrid named "pore", "organic",
// "inorganic", "organic_pore") and a label grid ("labels", phase codes, with background 0 =
// outside). Index (i, j, k) is voxel (x, y, z); the transform scales by the voxel spacing
// (dx, dy, dz), so world coordinates are in the spacing's unit.
//
// The label grid holds one byte per voxel by default (UInt8Grid below): a mixed 8x8x8 block costs
// 512 bytes instead of the 2048 of an openvdb::Int32Grid, which is what keeps a 1024^3 shale under
// 3 GiB (docs/benchmarks.md). OpenVDB registers no 8-bit grid type, so mesorock registers
// "Tree_uint8_5_4_3" in initialize_openvdb(); a program without that registration cannot open a
// file holding such a grid at all (OpenVDB refuses the whole file), which is why the label grid is
// written to its own file (labels.vdb) and phases.vdb keeps only standard grid types.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include <openvdb/openvdb.h>

#include "voxel/volume.h"

namespace mesorock::voxel {

// The 8-bit label grid type (registered by initialize_openvdb()).
using UInt8Tree = openvdb::tree::Tree4<std::uint8_t, 5, 4, 3>::Type;
using UInt8Grid = openvdb::Grid<UInt8Tree>;

// openvdb::initialize() and the registration of UInt8Grid, once per process (thread-safe).
void initialize_openvdb();

// Linear transform with the (possibly anisotropic) voxel spacing.
openvdb::math::Transform::Ptr voxel_transform(const Spacing& spacing);

enum class LabelGridType {
  kNone,   // no label grid (the phase masks hold the same information)
  kUInt8,  // UInt8Grid: 1 byte per voxel of mixed blocks; needs mesorock's registration to read
  kInt32,  // openvdb::Int32Grid: 4 bytes per voxel of mixed blocks; any OpenVDB program reads it
};
const char* label_grid_type_name(LabelGridType type);          // "none", "uint8", "int32"
LabelGridType parse_label_grid_type(const std::string& name);  // throws ConfigError

struct PhaseGridOptions {
  LabelGridType label_grid = LabelGridType::kUInt8;  // the grid "labels"
  bool phase_masks = true;                           // one MaskGrid per phase present
};

// Builds the grids from a uint8 phase-label volume, 8x8x8 blocks at a time in parallel. Blocks
// of one phase become tiles, not leaves, and the trees are pruned, so uniform regions cost little
// memory. Grids carry metadata "phase", "phase_code" and "unit". The label grid, when asked for,
// is the last grid of the result and is named "labels".
openvdb::GridPtrVec build_phase_grids(const Volume& labels, const PhaseGridOptions& options = {});

// Writes grids to `path` with file-level metadata (string key -> value), Blosc-compressed when
// OpenVDB has Blosc, else zlib. OpenVDB errors become IoError naming `display_name`.
void write_vdb(const std::filesystem::path& path, const openvdb::GridPtrVec& grids,
               const std::map<std::string, std::string>& metadata, const std::string& display_name);

}  // namespace mesorock::voxel
