#include "sim/solid_grid.h"

#include <hdf5.h>

#include <array>
#include <cmath>
#include <limits>
#include <system_error>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/hdf5_util.h"
#include "sim/model.h"

namespace mesorock::sim {

namespace fs = std::filesystem;
using namespace hdf5_util;

namespace {

// More voxels than this in one mask is not an image this tool can pack (2^33 bytes = 8 GiB).
constexpr std::int64_t kMaxMaskVoxels = std::int64_t(1) << 33;

std::array<double, 3> read_triple(hid_t obj, const char* name, const std::string& file) {
  const std::string where = std::string("/solid@") + name;
  if (H5Aexists(obj, name) <= 0) fail(file, where, "missing");
  Handle a = checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file, where, "cannot open");
  Handle space = checked(H5Aget_space(a.get()), H5Sclose, file, where, "cannot read dataspace");
  if (H5Sget_simple_extent_npoints(space.get()) != 3) fail(file, where, "expected 3 values");
  Handle type = checked(H5Aget_type(a.get()), H5Tclose, file, where, "cannot read datatype");
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) fail(file, where, "must be numeric");
  std::array<double, 3> v{};
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()), file, where, "cannot read");
  return v;
}

double read_scalar(hid_t obj, const char* name, const std::string& file) {
  const std::string where = std::string("/solid@") + name;
  if (H5Aexists(obj, name) <= 0) return 0;
  Handle a = checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file, where, "cannot open");
  Handle space = checked(H5Aget_space(a.get()), H5Sclose, file, where, "cannot read dataspace");
  if (H5Sget_simple_extent_npoints(space.get()) != 1) fail(file, where, "expected one value");
  double v = 0;
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v), file, where, "cannot read");
  return v;
}

}  // namespace

double SolidMask::porosity() const {
  if (solid.empty()) return 0;
  std::int64_t pore = 0;
  for (const std::uint8_t b : solid) pore += b == 0;
  return static_cast<double>(pore) / static_cast<double>(solid.size());
}

void SolidMask::check(const std::string& what) const {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1)
      throw ConfigError(what + ": the solid grid needs at least one voxel along every axis (got " +
                        std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                        std::to_string(dims[2]) + ")");
    if (!(voxel[a] > 0) || !std::isfinite(voxel[a]))
      throw ConfigError(what + ": voxel edges must be positive numbers of rc");
    if (!std::isfinite(origin[a])) throw ConfigError(what + ": the origin must be finite");
  }
  if (dims[0] > kMaxMaskVoxels / dims[1] / dims[2])
    throw ConfigError(what + ": the solid grid is too large (more than 2^33 voxels)");
  if (static_cast<std::int64_t>(solid.size()) != voxels())
    throw ConfigError(what + ": the solid grid holds " + std::to_string(solid.size()) +
                      " voxels, its dimensions say " + std::to_string(voxels()));
  if (!(nm_per_rc >= 0) || !std::isfinite(nm_per_rc))
    throw ConfigError(what + ": nm_per_rc must be a non-negative number");
}

void write_solid_file(const fs::path& path, const SolidMask& mask, const std::string& created_by,
                      const std::string& provenance_json) {
  silence_hdf5_errors();
  const std::string file = path.string();
  mask.check(file);
  write_atomically(path, [&](const fs::path& tmp) {
    Handle f = create_file(tmp, file);
    const std::vector<hsize_t> dims{static_cast<hsize_t>(mask.dims[2]),
                                    static_cast<hsize_t>(mask.dims[1]),
                                    static_cast<hsize_t>(mask.dims[0])};
    Handle space = simple_space(dims, file, "/solid");
    // Masks compress well (long runs of equal bytes): chunked layers with deflate.
    Handle dcpl =
        checked(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, file, "/solid", "cannot create dataset");
    const std::vector<hsize_t> chunk{1, dims[1], dims[2]};
    check(H5Pset_chunk(dcpl.get(), 3, chunk.data()), file, "/solid", "cannot create dataset");
    check(H5Pset_deflate(dcpl.get(), 4), file, "/solid", "cannot create dataset");
    Handle ds = checked(H5Dcreate2(f.get(), "solid", H5T_STD_U8LE, space.get(), H5P_DEFAULT,
                                   dcpl.get(), H5P_DEFAULT),
                        H5Dclose, file, "/solid", "cannot create dataset");
    check(H5Dwrite(ds.get(), H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, mask.solid.data()),
          file, "/solid", "write failed");
    write_attribute(ds.get(), "voxel_rc", "/solid@voxel_rc", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3},
                    mask.voxel.data(), file);
    write_attribute(ds.get(), "origin_rc", "/solid@origin_rc", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                    {3}, mask.origin.data(), file);
    write_attribute(ds.get(), "nm_per_rc", "/solid@nm_per_rc", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                    {}, &mask.nm_per_rc, file);
    write_string_attribute(f.get(), "mesorock_version", "/@mesorock_version", kVersion, file);
    write_string_attribute(f.get(), "git_commit", "/@git_commit", kGitCommit, file);
    write_string_attribute(f.get(), "created_by", "/@created_by", created_by, file);
    write_string_attribute(f.get(), "provenance", "/@provenance", provenance_json, file);
    if (!ds.close() || !f.close()) fail(file, "", "write failed");
  });
}

SolidMask read_solid_file(const fs::path& path) {
  silence_hdf5_errors();
  const std::string file = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(file, "", "no such file");
  if (!fs::is_regular_file(path, ec)) fail(file, "", "not a regular file");
  Handle f = checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, file, "",
                     "cannot open as an HDF5 file (not HDF5, unreadable or damaged)");
  if (H5Lexists(f.get(), "solid", H5P_DEFAULT) <= 0) fail(file, "/solid", "missing");
  Handle ds = checked(H5Dopen2(f.get(), "solid", H5P_DEFAULT), H5Dclose, file, "/solid",
                      "cannot open dataset");
  Handle type = checked(H5Dget_type(ds.get()), H5Tclose, file, "/solid", "cannot read datatype");
  if (H5Tget_class(type.get()) != H5T_INTEGER)
    fail(file, "/solid", "must be an integer dataset (1 = solid, 0 = pore)");
  Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, "/solid", "cannot read dataspace");
  const auto dims = extent(space.get(), file, "/solid");
  if (dims.size() != 3) fail(file, "/solid", "expected shape [nz, ny, nx], got " + dims_text(dims));
  SolidMask m;
  for (int a = 0; a < 3; ++a) {
    const hsize_t d = dims[static_cast<size_t>(2 - a)];
    if (d < 1 || d > static_cast<hsize_t>(kMaxMaskVoxels))
      fail(file, "/solid", "declares " + dims_text(dims) + " voxels: every axis needs 1 to 2^33");
    m.dims[static_cast<size_t>(a)] = static_cast<std::int64_t>(d);
  }
  if (m.dims[0] > kMaxMaskVoxels / m.dims[1] / m.dims[2])
    fail(file, "/solid", "declares " + dims_text(dims) + " voxels, more than 2^33 in all");
  // The declared size against what the file holds: a dataset whose storage is empty (or a
  // header that claims far more than any compression of bytes could hide) is damaged.
  const hsize_t stored = H5Dget_storage_size(ds.get());
  if (stored == 0)
    fail(file, "/solid", "declares " + dims_text(dims) + " voxels but holds no data");
  if (static_cast<double>(m.voxels()) > 1e5 * static_cast<double>(stored) + 1e6)
    fail(file, "/solid",
         "declares " + dims_text(dims) + " voxels but stores only " + std::to_string(stored) +
             " bytes");
  m.voxel = read_triple(ds.get(), "voxel_rc", file);
  m.origin = read_triple(ds.get(), "origin_rc", file);
  m.nm_per_rc = read_scalar(ds.get(), "nm_per_rc", file);
  m.solid.resize(static_cast<std::size_t>(m.voxels()));
  check(H5Dread(ds.get(), H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.solid.data()), file,
        "/solid", "read failed");
  for (std::uint8_t& b : m.solid) b = b != 0;
  try {
    m.check(file);
  } catch (const ConfigError& e) {
    throw IoError(e.what());
  }
  return m;
}

namespace {

// Whether the solid grid spans the box edge along axis a (then its indices wrap on a periodic
// axis): same start and length to a millionth of the edge.
bool grid_spans_axis(const SolidMask& g, const BoxSpec& box, int a) {
  const auto k = static_cast<size_t>(a);
  const double len = box.length(a), tol = 1e-6 * len;
  return std::abs(g.origin[k] - box.lo[k]) <= tol &&
         std::abs(static_cast<double>(g.dims[k]) * g.voxel[k] - len) <= tol;
}

}  // namespace

template <class Real>
SolidView<Real> solid_view_of(const SolidSpec& spec, const BoxSpec& box) {
  SolidView<Real> v;
  if (!spec.mask) return v;
  const SolidMask& g = *spec.mask;
  v.solid = g.solid.data();
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<size_t>(a);
    v.dims[a] = static_cast<int>(g.dims[k]);
    v.origin[a] = static_cast<Real>(g.origin[k]);
    v.voxel[a] = static_cast<Real>(g.voxel[k]);
    v.inv_voxel[a] = static_cast<Real>(1.0 / g.voxel[k]);
    v.periodic[a] = box.periodic[k] && grid_spans_axis(g, box, a);
    // Far enough that every depth up to the stop depth is found exactly.
    v.reach[a] = static_cast<int>(std::ceil(spec.stop_depth / g.voxel[k])) + 1;
  }
  v.bounce = spec.bounce;
  v.stop_depth = static_cast<Real>(spec.stop_depth);
  return v;
}
template SolidView<float> solid_view_of<float>(const SolidSpec&, const BoxSpec&);
template SolidView<double> solid_view_of<double>(const SolidSpec&, const BoxSpec&);

}  // namespace mesorock::sim
