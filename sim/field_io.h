#pragma once
// Binned fields on a regular 3-D grid and 1-D profiles, in HDF5 with XDMF 3 sidecars (so
// ParaView opens them) and, for profiles, CSV (spreadsheets, numpy, pandas, ParaView).
//
// Field file (write_field_file):
//   /fields/NAME   float64 [nz, ny, nx] (components == 1) or [nz, ny, nx, C]: cell-centred values,
//                  x fastest; attributes unit (string), components (int32)
//   /fields attributes: cells (int32[3], x y z), origin, spacing (float64[3], x y z; in
//                  length_unit), centering = "cell", axis_order = "z y x" (dataset axes)
// Profile file (write_profile_file): one axis, nbins bins
//   /profile/bin_edges  float64 [nbins + 1]     /profile/bin_centre  float64 [nbins]
//   /profile/NAME       float64 [nbins]         /profile/NAME_error  float64 [nbins] (if given)
//   each NAME dataset has attribute unit; /profile attributes: axis (int32, 0..2), axis_name
// Both files:
//   / attributes: mesorock_version, git_commit, created_by, provenance (JSON text), length_unit,
//                 step (uint64), time (float64), and every FieldFileMeta::attributes entry (string)
//   /units/NAME   float64 scalar with attribute unit, one per FieldFileMeta::units entry (only
//                 when units are given): one reduced unit of NAME in SI (see sim/units.h)
//
// Names (fields, extra attributes) are 1..64 characters from [A-Za-z0-9_.+-], so they are valid
// HDF5 link names, XML attribute values and CSV headers as they stand. Values may be NaN (e.g. a
// mean over a bin without samples); ParaView shows NaN as a missing value.
//
// Every write is atomic (temporary file + rename): on failure the target is untouched, no
// temporary is left, and an IoError names the file.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sim/units.h"

namespace mesorock::sim {

struct FieldGrid {
  std::array<int, 3> cells{1, 1, 1};       // cells along x, y, z (each >= 1)
  std::array<double, 3> origin{0, 0, 0};   // lower corner of cell (0,0,0)
  std::array<double, 3> spacing{1, 1, 1};  // cell edge lengths (> 0)

  std::size_t cell_count() const {
    return static_cast<std::size_t>(cells[0]) * static_cast<std::size_t>(cells[1]) *
           static_cast<std::size_t>(cells[2]);
  }
  // Flat index of cell (i, j, k): ((k * ny + j) * nx + i), x fastest.
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(cells[1]) +
            static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(cells[0]) +
           static_cast<std::size_t>(i);
  }
};

struct FieldData {
  std::string name;
  int components = 1;  // 1 (Scalar), 3 (Vector), 6 (Tensor6: xx yy zz xy yz xz), 9 (Tensor)
  std::string unit;    // e.g. "1/rc^3", "rc/tau", "m/s"
  // cell_count() * components values: index = grid.index(i, j, k) * components + c.
  std::vector<double> values;
};

struct FieldFileMeta {
  std::uint64_t step = 0;
  double time = 0;
  std::string created_by;          // e.g. "rockflow run"
  std::string provenance_json;     // JSON text: scene, parameters (stored as given)
  std::string length_unit = "rc";  // unit of origin, spacing and bin edges
  std::vector<std::pair<std::string, std::string>> attributes;  // extra root string attributes
  std::vector<UnitEntry> units;  // UnitSystem::describe() when physical units apply
};

// Writes the grid fields to `h5` atomically. Throws IoError (naming the file) on an invalid grid
// (cells < 1, non-finite origin, spacing not finite and positive), a field whose value count is
// not cell_count() * components, a components value other than 1, 3, 6, 9, an invalid or
// duplicate name, an extra attribute that would overwrite a standard one, or a failed write.
void write_field_file(const std::filesystem::path& h5, const FieldGrid& grid,
                      const std::vector<FieldData>& fields, const FieldFileMeta& meta);

// Writes an XDMF 3 sidecar for a field file: 3DCoRectMesh topology with node dimensions
// "nz+1 ny+1 nx+1", ORIGIN_DXDYDZ geometry, one Center="Cell" attribute per field (Scalar,
// Vector, Tensor6 or Tensor). The h5 path is written relative to the .xmf file's folder. `time`,
// when given, becomes the grid's Time. Validates like write_field_file (values are not needed:
// only names and components are used).
void write_field_xdmf(const std::filesystem::path& xmf, const std::filesystem::path& h5,
                      const FieldGrid& grid, const std::vector<FieldData>& fields,
                      std::optional<double> time = std::nullopt);

struct ProfileField {
  std::string name;
  std::string unit;
  std::vector<double> mean;   // one value per bin
  std::vector<double> error;  // empty (no error estimate) or one value per bin
};

// Writes a 1-D profile along `axis` (0 = x, 1 = y, 2 = z) with bins [edges[b], edges[b+1]) to an
// HDF5 file. Throws IoError (naming the file) on an axis outside 0..2, fewer than 2 edges, edges
// not finite and strictly increasing, a mean or error array of the wrong length, invalid or
// duplicate names (NAME_error counts as a name), or a failed write.
void write_profile_file(const std::filesystem::path& h5, int axis,
                        const std::vector<double>& bin_edges,
                        const std::vector<ProfileField>& fields, const FieldFileMeta& meta);

// Writes an XDMF 3 sidecar for a profile file, so ParaView shows the profile as a row of cells:
// a 3DRectMesh whose coordinates along `axis` are the bin edges (from /profile/bin_edges) and
// {0, 1} along the other two axes, with one Center="Cell" Scalar attribute per mean and error
// dataset. Validates like write_profile_file (means and errors only for their lengths).
void write_profile_xdmf(const std::filesystem::path& xmf, const std::filesystem::path& h5, int axis,
                        const std::vector<double>& bin_edges,
                        const std::vector<ProfileField>& fields,
                        std::optional<double> time = std::nullopt);

// The same profile as CSV: '#' comment lines (mesorock version and commit, created_by, step,
// time, axis, length unit, provenance on one line, extra attributes, unit system, each column's
// unit), then a header row "bin_lo,bin_hi,bin_centre,NAME[,NAME_error],..." and one row per bin.
// Numbers are the shortest text that reads back to the same double; NaN is "nan". pandas:
// read_csv(path, comment='#').
void write_profile_csv(const std::filesystem::path& csv, int axis,
                       const std::vector<double>& bin_edges,
                       const std::vector<ProfileField>& fields, const FieldFileMeta& meta);

}  // namespace mesorock::sim
