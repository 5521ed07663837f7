#pragma once
// Phase grids in OpenVDB: one sparse mask per phase (openvdb::MaskGrid named "pore", "organic",
// "inorganic", "organic_pore") and a label grid (openvdb::Int32Grid "labels", phase codes, with
// background 0 = outside). Index (i, j, k) is voxel (x, y, z); the transform scales by the voxel
// spacing (dx, dy, dz), so world coordinates are in the spacing's unit.
#include <filesystem>
#include <map>
#include <string>

#include <openvdb/openvdb.h>

#include "voxel/volume.h"

namespace mesorock::voxel {

// openvdb::initialize(), once per process (thread-safe).
void initialize_openvdb();

// Linear transform with the (possibly anisotropic) voxel spacing.
openvdb::math::Transform::Ptr voxel_transform(const Spacing& spacing);

struct PhaseGridOptions {
  bool label_grid = true;   // the Int32Grid "labels"
  bool phase_masks = true;  // one MaskGrid per phase present
};

// Builds the grids from a uint8 phase-label volume, 8x8x8 blocks at a time in parallel. Blocks
// of one phase become tiles, not leaves, and the trees are pruned, so uniform regions cost little
// memory. Grids carry metadata "phase", "phase_code" and "unit".
openvdb::GridPtrVec build_phase_grids(const Volume& labels, const PhaseGridOptions& options = {});

// Writes grids to `path` with file-level metadata (string key -> value), Blosc-compressed when
// OpenVDB has Blosc, else zlib. OpenVDB errors become IoError naming `display_name`.
void write_vdb(const std::filesystem::path& path, const openvdb::GridPtrVec& grids,
               const std::map<std::string, std::string>& metadata, const std::string& display_name);

}  // namespace mesorock::voxel
