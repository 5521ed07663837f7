#pragma once
// One dataset of an HDF5 file (C API).
//
// Types: 8-bit signed/unsigned, 16-bit unsigned, 32-bit float integers/floats, and h5py's bool
// (an int8 enum FALSE/TRUE). Spacing comes from dataset attributes: "spacing" (3 values, z y x)
// with "unit" (a string), or the ilastik/ImageJ convention "element_size_um" (z y x, micrometres).
#include <filesystem>
#include <string>
#include <vector>

#include "voxel/io_common.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

// Reads `dataset` ("/group/name"). With an empty name the file must hold exactly one 2-D or 3-D
// dataset; otherwise the error lists them.
Volume read_hdf5(const std::filesystem::path& path, const std::string& dataset,
                 const ReadLimits& limits = {}, ReadReport* report = nullptr);

// The 2-D and 3-D datasets in a file, as absolute paths.
std::vector<std::string> list_hdf5_datasets(const std::filesystem::path& path);

// Writes `volume` as dataset `dataset` (intermediate groups are created) with "spacing" and
// "unit" attributes. bool is written as h5py writes it (an int8 enum), so h5py reads it back as
// bool.
void write_hdf5(const Volume& volume, const std::filesystem::path& path,
                const std::string& dataset);

}  // namespace mesorock::voxel
