#pragma once
// NumPy .npy arrays and .npz archives of them.
//
// Why hand-written: the .npy format is a magic string, a Python dict literal and the raw data;
// Debian packages no C++ reader for it (cnpy is not packaged), and the format is fixed by NumPy's
// NEP 1. The .npz container is read by voxel/zip_reader.h.
//
// dtypes: bool, int8, uint8, uint16 and float32 (either byte order); C or Fortran order (Fortran
// arrays are transposed to C order while streaming, one plane at a time, never as a second full
// copy). A 3-D array (a, b, c) is read as (nz, ny, nx) = (a, b, c); a 2-D array as one slice.
#include <filesystem>
#include <string>
#include <vector>

#include "voxel/io_common.h"
#include "voxel/volume.h"

namespace mesorock::voxel {

Volume read_npy(const std::filesystem::path& path, const ReadLimits& limits = {},
                ReadReport* report = nullptr);

// Reads array `array` ("im" or "im.npy") from an .npz. With an empty name the archive must hold
// exactly one array; otherwise the error lists the names it holds.
Volume read_npz(const std::filesystem::path& path, const std::string& array,
                const ReadLimits& limits = {}, ReadReport* report = nullptr);

// Array names in an .npz ("im.npy" is listed as "im").
std::vector<std::string> list_npz_arrays(const std::filesystem::path& path);

// Writes a version 1.0 .npy in C order, or in Fortran order (for interoperability tests).
void write_npy(const Volume& volume, const std::filesystem::path& path, bool fortran_order = false);

}  // namespace mesorock::voxel
