#pragma once
// Headerless raw volumes, and MetaImage (.mhd header + .raw data, or .mha with the data inline).
//
// Why hand-written: MetaImage is a few "key = value" lines and a raw (or zlib) block. The library
// that reads it, ITK/MetaIO (Debian libinsighttoolkit4-dev), is a very large dependency outside
// the project's list for a reader this small.
//
// MetaImage has no length unit. Next to every .mhd it writes, mesorock writes a JSON sidecar
// (vol.mhd -> vol.json) holding the unit, the dtype (bool is stored as MET_UCHAR) and the
// provenance; read_mhd() uses it when present.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "voxel/io_common.h"
#include "voxel/staged_output.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

struct RawOptions {
  Shape shape;                  // (nz, ny, nx), required
  DType dtype = DType::kUInt8;  // required in practice: the file cannot say
  Spacing spacing;
  bool big_endian = false;
  std::uint64_t header_bytes = 0;  // bytes to skip at the start of the file
};

// Reads a headerless raw file. Its size must be exactly header_bytes + the volume's bytes: a file
// that is shorter is truncated, one that is longer was probably described with the wrong shape.
Volume read_raw(const std::filesystem::path& path, const RawOptions& options,
                const ReadLimits& limits = {}, ReadReport* report = nullptr);

// Reads a MetaImage header and its data (external file, LOCAL, zlib-compressed or not).
Volume read_mhd(const std::filesystem::path& header, const ReadLimits& limits = {},
                ReadReport* report = nullptr);

// Sidecar path of a header: "dir/vol.mhd" -> "dir/vol.json".
std::filesystem::path sidecar_path(const std::filesystem::path& header);

// Stages `header_target` (.mhd), its .raw and its .json sidecar in `outputs`. The sidecar holds
// {"generator": "mesorock", version, unit, dtype, shape, spacing} merged with `provenance`.
void write_mhd(const Volume& volume, StagedOutputs& outputs,
               const std::filesystem::path& header_target,
               const nlohmann::json& provenance = nlohmann::json::object());

// Writes the raw voxels (native little-endian) to an open path.
void write_raw(const Volume& volume, const std::filesystem::path& path,
               const std::string& display_name);

}  // namespace mesorock::voxel
