#pragma once
// TIFF stacks through libtiff: a folder of 2-D slices, or one multi-page file.
//
// Pixel types: 1-bit (bool), 8-bit signed/unsigned, 16-bit unsigned, 32-bit float; one sample per
// pixel; strips or tiles; any compression libtiff decodes. Rows are kept as stored (the Orientation
// tag is not applied), as ImageJ and tifffile do, so arrays agree with what those tools show.
// Voxel spacing is read from an ImageJ description (unit=, spacing=) with X/YResolution; other
// resolution tags are too often a scanner's 72 dpi to be trusted.
#include <filesystem>
#include <string>
#include <vector>

#include "voxel/io_common.h"
#include "voxel/staged_output.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

// Orders file names as people number slices: "slice_2" before "slice_10".
bool natural_less(const std::string& a, const std::string& b);

// The .tif/.tiff files of a folder (hidden files skipped), in natural order.
std::vector<std::filesystem::path> list_tiff_slices(const std::filesystem::path& dir);

// A folder of single-page slices, z = slice index in natural order. Every slice must agree in
// size and type with the first; this is checked for all slices before any voxel memory is taken.
Volume read_tiff_folder(const std::filesystem::path& dir, const ReadLimits& limits = {},
                        ReadReport* report = nullptr);

// A TIFF file; each page is one z slice.
Volume read_tiff_file(const std::filesystem::path& file, const ReadLimits& limits = {},
                      ReadReport* report = nullptr);

struct TiffWriteOptions {
  bool deflate = false;                 // Adobe Deflate (zlib) with horizontal predictor
  std::string slice_prefix = "slice_";  // for write_tiff_slices: slice_0000.tif, slice_0001.tif...
};

// Writes one file per z slice into `subdir` of `outputs` (staged, so all appear or none do).
// Returns the number of files.
std::size_t write_tiff_slices(const Volume& volume, StagedOutputs& outputs,
                              const std::filesystem::path& subdir,
                              const TiffWriteOptions& options = {});

// Writes a multi-page TIFF to `path` (a temporary path from StagedOutputs or write_atomically).
// `display_name` is used in error messages.
void write_tiff_file(const Volume& volume, const std::filesystem::path& path,
                     const TiffWriteOptions& options = {}, const std::string& display_name = "");

}  // namespace mesorock::voxel
