#include "tiledb/database.h"

#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/hdf5_util.h"

namespace mesorock::tiledb {

namespace fs = std::filesystem;
using namespace sim::hdf5_util;

namespace {

constexpr const char* kFormat = "mesorock tile database 1";

std::string set_name(std::size_t k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "set_%03zu", k);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Writing

void put_double(hid_t obj, const char* name, double v, const std::string& where,
                const std::string& file) {
  write_attribute(obj, name, where + "@" + name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}, &v, file);
}
void put_doubles(hid_t obj, const char* name, const std::array<double, 3>& v,
                 const std::string& where, const std::string& file) {
  write_attribute(obj, name, where + "@" + name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3}, v.data(),
                  file);
}
void put_int(hid_t obj, const char* name, std::int64_t v, const std::string& where,
             const std::string& file) {
  write_attribute(obj, name, where + "@" + name, H5T_STD_I64LE, H5T_NATIVE_INT64, {}, &v, file);
}
void put_string(hid_t obj, const char* name, const std::string& v, const std::string& where,
                const std::string& file) {
  write_string_attribute(obj, name, where + "@" + name, v, file);
}

void write_set(hid_t parent, const std::string& name, const TileSet& s, const std::string& file) {
  const std::string where = "/tiles/" + name;
  Handle g = create_group(parent, name.c_str(), where, file);
  const hsize_t n = static_cast<hsize_t>(s.particles());
  write_dataset(g.get(), "offsets", where + "/offsets", H5T_STD_I64LE, H5T_NATIVE_INT64,
                {static_cast<hsize_t>(s.offsets.size())}, s.offsets.data(), file);
  write_dataset(g.get(), "position", where + "/position", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3},
                s.position.data(), file);
  write_dataset(g.get(), "velocity", where + "/velocity", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3},
                s.velocity.data(), file);
  const hid_t h = g.get();
  const TileKey& k = s.key;
  put_string(h, "name", k.str(), where, file);
  put_string(h, "role", to_string(k.role), where, file);
  put_double(h, "density", k.density, where, file);
  put_doubles(h, "edge_xyz", k.edge, where, file);
  put_double(h, "A", k.A, where, file);
  put_double(h, "B", k.B, where, file);
  put_double(h, "rd", k.rd, where, file);
  put_double(h, "gamma", k.gamma, where, file);
  put_double(h, "kBT", k.kBT, where, file);
  put_string(h, "density_kernel", sim::to_string(k.density_kernel), where, file);
  const TileSetStats& m = s.stats;
  put_double(h, "measured_density", m.density, where, file);
  put_double(h, "temperature", m.temperature, where, file);
  put_double(h, "temperature_error", m.temperature_error, where, file);
  put_double(h, "temperature_at_cuts", m.temperature_at_cuts, where, file);
  put_double(h, "mean_count", m.mean_count, where, file);
  put_double(h, "count_std", m.count_std, where, file);
  const TileBuildRecord& b = s.build;
  put_int(h, "seed", static_cast<std::int64_t>(b.seed), where, file);
  put_int(h, "relax_steps", static_cast<std::int64_t>(b.relax_steps), where, file);
  put_int(h, "equilibration_steps", static_cast<std::int64_t>(b.equilibration_steps), where, file);
  put_int(h, "decorrelation_steps", static_cast<std::int64_t>(b.decorrelation_steps), where, file);
  put_double(h, "dt", b.dt, where, file);
  put_doubles(h, "box_xyz", b.box, where, file);
  const std::array<double, 3> per{static_cast<double>(b.tiles_per_box[0]),
                                  static_cast<double>(b.tiles_per_box[1]),
                                  static_cast<double>(b.tiles_per_box[2])};
  put_doubles(h, "tiles_per_box_xyz", per, where, file);
  put_int(h, "cuts", b.cuts, where, file);
  put_int(h, "box_particles", b.box_particles, where, file);
  put_double(h, "seconds", b.seconds, where, file);
  put_string(h, "backend", b.backend, where, file);
  put_string(h, "mesorock_version", b.mesorock_version, where, file);
  put_string(h, "git_commit", b.git_commit, where, file);
  put_string(h, "provenance", b.provenance_json, where, file);
}

// ---------------------------------------------------------------------------------------------
// Reading

Handle open_attr(hid_t obj, const char* name, const std::string& where, const std::string& file) {
  if (H5Aexists(obj, name) <= 0) fail(file, where + "@" + name, "missing");
  return checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file, where + "@" + name,
                 "cannot open attribute");
}

std::size_t attr_points(hid_t attr, const std::string& file, const std::string& where) {
  Handle space = checked(H5Aget_space(attr), H5Sclose, file, where, "cannot read dataspace");
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) fail(file, where, "cannot read dataspace");
  return static_cast<std::size_t>(n);
}

template <class T>
std::vector<T> get_numbers(hid_t obj, const char* name, hid_t mem_type, std::size_t expect,
                           const std::string& where, const std::string& file) {
  Handle a = open_attr(obj, name, where, file);
  const std::string w = where + "@" + name;
  Handle type = checked(H5Aget_type(a.get()), H5Tclose, file, w, "cannot read datatype");
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_INTEGER && cls != H5T_FLOAT) fail(file, w, "must be a number");
  if (attr_points(a.get(), file, w) != expect)
    fail(file, w, "expected " + std::to_string(expect) + " values");
  std::vector<T> out(expect);
  check(H5Aread(a.get(), mem_type, out.data()), file, w, "cannot read attribute");
  return out;
}

double get_double(hid_t obj, const char* name, const std::string& where, const std::string& file) {
  const double v = get_numbers<double>(obj, name, H5T_NATIVE_DOUBLE, 1, where, file)[0];
  if (!std::isfinite(v)) fail(file, where + "@" + name, "must be finite");
  return v;
}
std::array<double, 3> get_doubles(hid_t obj, const char* name, const std::string& where,
                                  const std::string& file) {
  const auto v = get_numbers<double>(obj, name, H5T_NATIVE_DOUBLE, 3, where, file);
  for (double d : v)
    if (!std::isfinite(d)) fail(file, where + "@" + name, "must be finite");
  return {v[0], v[1], v[2]};
}
std::int64_t get_int(hid_t obj, const char* name, const std::string& where,
                     const std::string& file) {
  return get_numbers<std::int64_t>(obj, name, H5T_NATIVE_INT64, 1, where, file)[0];
}

std::string get_string(hid_t obj, const char* name, const std::string& where,
                       const std::string& file) {
  Handle a = open_attr(obj, name, where, file);
  const std::string w = where + "@" + name;
  Handle type = checked(H5Aget_type(a.get()), H5Tclose, file, w, "cannot read datatype");
  if (H5Tget_class(type.get()) != H5T_STRING) fail(file, w, "must be a string");
  if (H5Tis_variable_str(type.get()) <= 0) fail(file, w, "must be a variable-length string");
  Handle mem = vlen_string_type(file);
  char* s = nullptr;
  check(H5Aread(a.get(), mem.get(), &s), file, w, "cannot read attribute");
  std::string out = s ? s : "";
  if (s) H5free_memory(s);
  return out;
}

template <class T>
std::vector<T> get_dataset(hid_t g, const char* name, hid_t mem_type, hsize_t cols,
                           const std::string& where, const std::string& file, hsize_t* rows) {
  const std::string w = where + "/" + name;
  if (H5Lexists(g, name, H5P_DEFAULT) <= 0) fail(file, w, "missing");
  Handle ds = checked(H5Dopen2(g, name, H5P_DEFAULT), H5Dclose, file, w, "cannot open dataset");
  Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, w, "cannot read dataspace");
  const auto dims = extent(space.get(), file, w);
  const bool ok = cols == 0 ? dims.size() == 1 : (dims.size() == 2 && dims[1] == cols);
  if (!ok) fail(file, w, "unexpected shape " + dims_text(dims));
  check_declared_size(ds.get(), dims, sizeof(T), file, w);
  std::vector<T> out(static_cast<std::size_t>(dims[0] * (cols == 0 ? 1 : cols)));
  if (!out.empty())
    check(H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), file, w,
          "read failed");
  *rows = dims[0];
  return out;
}

TileSet read_set(hid_t g, const std::string& where, const std::string& file) {
  TileSet s;
  TileKey& k = s.key;
  try {
    k.role = parse_tile_role(get_string(g, "role", where, file));
    const std::string kernel = get_string(g, "density_kernel", where, file);
    if (kernel == "warren") {
      k.density_kernel = sim::DensityKernelKind::Warren;
    } else if (kernel == "lucy") {
      k.density_kernel = sim::DensityKernelKind::Lucy;
    } else {
      fail(file, where + "@density_kernel", "unknown kernel '" + kernel + "'");
    }
  } catch (const ConfigError& e) {
    fail(file, where + "@role", e.what());
  }
  k.density = get_double(g, "density", where, file);
  k.edge = get_doubles(g, "edge_xyz", where, file);
  k.A = get_double(g, "A", where, file);
  k.B = get_double(g, "B", where, file);
  k.rd = get_double(g, "rd", where, file);
  k.gamma = get_double(g, "gamma", where, file);
  k.kBT = get_double(g, "kBT", where, file);
  try {
    k.validate();
  } catch (const ConfigError& e) {
    fail(file, where, e.what());
  }
  TileSetStats& m = s.stats;
  m.density = get_double(g, "measured_density", where, file);
  m.temperature = get_double(g, "temperature", where, file);
  m.temperature_error = get_double(g, "temperature_error", where, file);
  m.temperature_at_cuts = get_double(g, "temperature_at_cuts", where, file);
  m.mean_count = get_double(g, "mean_count", where, file);
  m.count_std = get_double(g, "count_std", where, file);
  TileBuildRecord& b = s.build;
  b.seed = static_cast<std::uint64_t>(get_int(g, "seed", where, file));
  b.relax_steps = static_cast<std::uint64_t>(get_int(g, "relax_steps", where, file));
  b.equilibration_steps =
      static_cast<std::uint64_t>(get_int(g, "equilibration_steps", where, file));
  b.decorrelation_steps =
      static_cast<std::uint64_t>(get_int(g, "decorrelation_steps", where, file));
  b.dt = get_double(g, "dt", where, file);
  b.box = get_doubles(g, "box_xyz", where, file);
  const auto per = get_doubles(g, "tiles_per_box_xyz", where, file);
  for (int a = 0; a < 3; ++a)
    b.tiles_per_box[static_cast<std::size_t>(a)] =
        static_cast<int>(per[static_cast<std::size_t>(a)]);
  b.cuts = static_cast<int>(get_int(g, "cuts", where, file));
  b.box_particles = get_int(g, "box_particles", where, file);
  b.seconds = get_double(g, "seconds", where, file);
  b.backend = get_string(g, "backend", where, file);
  b.mesorock_version = get_string(g, "mesorock_version", where, file);
  b.git_commit = get_string(g, "git_commit", where, file);
  b.provenance_json = get_string(g, "provenance", where, file);

  hsize_t rows = 0, prow = 0, vrow = 0;
  s.offsets = get_dataset<std::int64_t>(g, "offsets", H5T_NATIVE_INT64, 0, where, file, &rows);
  s.position = get_dataset<double>(g, "position", H5T_NATIVE_DOUBLE, 3, where, file, &prow);
  s.velocity = get_dataset<double>(g, "velocity", H5T_NATIVE_DOUBLE, 3, where, file, &vrow);
  if (rows < 1) fail(file, where + "/offsets", "must hold at least one entry");
  if (vrow != prow)
    fail(file, where + "/velocity",
         std::to_string(vrow) + " rows, but position has " + std::to_string(prow));
  if (s.offsets.front() != 0 || s.offsets.back() != static_cast<std::int64_t>(prow))
    fail(file, where + "/offsets", "must run from 0 to the particle count " + std::to_string(prow));
  for (std::size_t t = 0; t + 1 < s.offsets.size(); ++t)
    if (s.offsets[t + 1] < s.offsets[t])
      fail(file, where + "/offsets", "decreases at entry " + std::to_string(t + 1));
  for (double v : s.position)
    if (!std::isfinite(v)) fail(file, where + "/position", "holds a non-finite value");
  for (double v : s.velocity)
    if (!std::isfinite(v)) fail(file, where + "/velocity", "holds a non-finite value");
  return s;
}

}  // namespace

const TileSet* TileDatabase::find(const TileKey& key) const {
  for (const TileSet& s : sets)
    if (s.key.matches(key)) return &s;
  return nullptr;
}

bool TileDatabase::put(TileSet set) {
  for (TileSet& s : sets) {
    if (s.key.matches(set.key)) {
      s = std::move(set);
      return true;
    }
  }
  sets.push_back(std::move(set));
  return false;
}

void write_tile_database(const fs::path& path, const TileDatabase& db) {
  silence_hdf5_errors();
  const std::string file = path.string();
  write_atomically(path, [&](const fs::path& tmp) {
    Handle f = create_file(tmp, file);
    write_string_attribute(f.get(), "format", "/@format", kFormat, file);
    write_string_attribute(f.get(), "mesorock_version", "/@mesorock_version", kVersion, file);
    write_string_attribute(f.get(), "git_commit", "/@git_commit", kGitCommit, file);
    {
      Handle tiles = create_group(f.get(), "tiles", "/tiles", file);
      for (std::size_t k = 0; k < db.sets.size(); ++k)
        write_set(tiles.get(), set_name(k), db.sets[k], file);
    }
    if (!f.close()) fail(file, "", "cannot close file (write failed)");
  });
}

TileDatabase read_tile_database(const fs::path& path) {
  silence_hdf5_errors();
  const std::string file = path.string();
  Handle f = open_file_for_reading(path, file);
  const std::string format = get_string(f.get(), "format", "/", file);
  if (format != kFormat)
    fail(file, "/@format", "not a mesorock tile database (format '" + format + "')");
  if (H5Lexists(f.get(), "tiles", H5P_DEFAULT) <= 0) fail(file, "/tiles", "missing");
  Handle tiles =
      checked(H5Gopen2(f.get(), "tiles", H5P_DEFAULT), H5Gclose, file, "/tiles", "not a group");
  H5G_info_t info;
  check(H5Gget_info(tiles.get(), &info), file, "/tiles", "cannot read group");
  TileDatabase db;
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    const std::string name = set_name(static_cast<std::size_t>(k));
    const std::string where = "/tiles/" + name;
    if (H5Lexists(tiles.get(), name.c_str(), H5P_DEFAULT) <= 0)
      fail(file, where, "missing (sets are numbered set_000, set_001, ...)");
    Handle g = checked(H5Gopen2(tiles.get(), name.c_str(), H5P_DEFAULT), H5Gclose, file, where,
                       "not a group");
    db.sets.push_back(read_set(g.get(), where, file));
  }
  return db;
}

}  // namespace mesorock::tiledb
