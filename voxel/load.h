#pragma once
// One entry point for every input format: the format is recognised from the file's first bytes
// (and the extension where bytes cannot tell, as for .mhd and headerless raw).
#include <filesystem>
#include <optional>
#include <string>

#include "voxel/io_common.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

struct LoadOptions {
  // Headerless raw input only (the file cannot describe itself).
  std::optional<Shape> shape;
  std::optional<DType> dtype;
  bool big_endian = false;
  std::uint64_t header_bytes = 0;
  // Overrides whatever spacing the file's metadata gives (values and unit), or only the unit.
  std::optional<Spacing> spacing;
  std::optional<std::string> unit;
  std::string array;    // member of an .npz ("" : the only one)
  std::string dataset;  // dataset of an HDF5 file ("" : the only image dataset)
  ReadLimits limits;
};

enum class Format { kTiffFolder, kTiff, kNpy, kNpz, kHdf5, kMetaImage, kRaw };
const char* format_name(Format format);

// Recognises the format of `input`, or throws IoError naming the file.
Format detect_format(const std::filesystem::path& input, const LoadOptions& options = {});

// Loads `input` (a folder of TIFF slices or a file). Warnings and the spacing's origin go to
// `report`.
Volume load_volume(const std::filesystem::path& input, const LoadOptions& options = {},
                   ReadReport* report = nullptr);

}  // namespace mesorock::voxel
