#include "sim/particle_io.h"

#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "sim/hdf5_util.h"

namespace mesorock::sim {

namespace fs = std::filesystem;
using namespace hdf5_util;

namespace {

Handle open_dataset(hid_t group, const char* name, const std::string& where,
                    const std::string& file) {
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) fail(file, where, "missing");
  return checked(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose, file, where, "cannot open dataset");
}

// Reads dataset `name` of class `want` with shape [N] (cols == 0) or [N, cols]; returns N.
template <class T>
std::vector<T> read_dataset(hid_t group, const char* name, hid_t mem_type, H5T_class_t want,
                            hsize_t cols, std::optional<hsize_t> expect_rows,
                            const std::string& file, hsize_t* rows_out) {
  const std::string where = std::string("/particles/") + name;
  Handle ds = open_dataset(group, name, where, file);
  Handle type = checked(H5Dget_type(ds.get()), H5Tclose, file, where, "cannot read datatype");
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != want)
    fail(file, where,
         std::string("must be ") + class_name(want) + " (got " + class_name(cls) + ")");
  Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, where, "cannot read dataspace");
  const auto dims = extent(space.get(), file, where);
  const bool shape_ok = cols == 0 ? dims.size() == 1 : (dims.size() == 2 && dims[1] == cols);
  if (!shape_ok)
    fail(file, where,
         std::string("expected shape ") + (cols == 0 ? "[N]" : "[N," + std::to_string(cols) + "]") +
             ", got " + dims_text(dims));
  check_declared_size(ds.get(), dims, sizeof(T), file, where);
  const hsize_t rows = dims[0];
  if (expect_rows && rows != *expect_rows)
    fail(file, where,
         std::to_string(rows) + (cols == 0 ? " entries" : " rows") + ", expected " +
             std::to_string(*expect_rows));
  std::vector<T> out(static_cast<size_t>(rows * (cols == 0 ? 1 : cols)));
  if (!out.empty())
    check(H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), file, where,
          "read failed");
  if (rows_out) *rows_out = rows;
  return out;
}

struct AttrData {
  Handle attr;
  Handle type;
  hsize_t npoints = 0;
  std::vector<hsize_t> dims;
};

std::optional<AttrData> open_attribute(hid_t obj, const char* name, const std::string& where,
                                       const std::string& file, bool required) {
  const htri_t exists = H5Aexists(obj, name);
  if (exists < 0) fail(file, where, "cannot query attribute");
  if (exists == 0) {
    if (required) fail(file, where, "missing");
    return std::nullopt;
  }
  AttrData a;
  a.attr = checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file, where, "cannot open attribute");
  a.type = checked(H5Aget_type(a.attr.get()), H5Tclose, file, where, "cannot read datatype");
  Handle space =
      checked(H5Aget_space(a.attr.get()), H5Sclose, file, where, "cannot read dataspace");
  const H5S_class_t sc = H5Sget_simple_extent_type(space.get());
  if (sc == H5S_NULL) {
    a.npoints = 0;
  } else {
    a.dims = extent(space.get(), file, where);
    a.npoints = 1;
    for (hsize_t d : a.dims) a.npoints *= d;
  }
  return a;
}

// A numeric attribute with exactly `n` values (n == 1 accepts a scalar or a 1-element array).
template <class T>
std::optional<std::vector<T>> read_numeric_attribute(hid_t obj, const char* name,
                                                     const std::string& where, hid_t mem_type,
                                                     H5T_class_t want, hsize_t n,
                                                     const std::string& file, bool required) {
  auto a = open_attribute(obj, name, where, file, required);
  if (!a) return std::nullopt;
  const H5T_class_t cls = H5Tget_class(a->type.get());
  if (cls != want && !(want == H5T_FLOAT && cls == H5T_INTEGER))
    fail(file, where,
         std::string("must be ") + class_name(want) + " (got " + class_name(cls) + ")");
  if (a->npoints != n || a->dims.size() > 1)
    fail(file, where,
         "expected " + std::to_string(n) + (n == 1 ? " value" : " values") + ", got shape " +
             dims_text(a->dims));
  std::vector<T> out(static_cast<size_t>(n));
  check(H5Aread(a->attr.get(), mem_type, out.data()), file, where, "cannot read attribute");
  return out;
}

// A string attribute (scalar or 1-D array; variable- or fixed-length).
std::optional<std::vector<std::string>> read_string_attribute(hid_t obj, const char* name,
                                                              const std::string& where,
                                                              const std::string& file,
                                                              bool required) {
  auto a = open_attribute(obj, name, where, file, required);
  if (!a) return std::nullopt;
  if (H5Tget_class(a->type.get()) != H5T_STRING)
    fail(file, where,
         std::string("must be a string (got ") + class_name(H5Tget_class(a->type.get())) + ")");
  if (a->dims.size() > 1) fail(file, where, "expected a 1-D array, got " + dims_text(a->dims));
  const size_t n = static_cast<size_t>(a->npoints);
  std::vector<std::string> out;
  out.reserve(n);
  if (n == 0) return out;
  const htri_t is_var = H5Tis_variable_str(a->type.get());
  if (is_var < 0) fail(file, where, "cannot read datatype");
  Handle mem = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, where, "cannot create string type");
  // HDF5 does not convert between ASCII and UTF-8: read in the stored character set.
  check(H5Tset_cset(mem.get(), H5Tget_cset(a->type.get())), file, where,
        "cannot create string type");
  if (is_var > 0) {
    check(H5Tset_size(mem.get(), H5T_VARIABLE), file, where, "cannot create string type");
    std::vector<char*> buf(n, nullptr);
    const herr_t r = H5Aread(a->attr.get(), mem.get(), buf.data());
    for (char* s : buf) {
      if (r >= 0) out.emplace_back(s ? s : "");
      if (s) H5free_memory(s);
    }
    check(r, file, where, "cannot read attribute");
  } else {
    const size_t len = H5Tget_size(a->type.get());
    if (len == 0) fail(file, where, "cannot read datatype");
    check(H5Tset_size(mem.get(), len), file, where, "cannot create string type");
    check(H5Tset_strpad(mem.get(), H5Tget_strpad(a->type.get())), file, where,
          "cannot create string type");
    std::vector<char> buf(n * len, '\0');
    check(H5Aread(a->attr.get(), mem.get(), buf.data()), file, where, "cannot read attribute");
    const bool space_padded = H5Tget_strpad(a->type.get()) == H5T_STR_SPACEPAD;
    for (size_t i = 0; i < n; ++i) {
      std::string s(buf.data() + i * len, len);
      s = s.substr(0, s.find('\0'));
      if (space_padded) s.erase(s.find_last_not_of(' ') + 1);
      out.push_back(s);
    }
  }
  return out;
}

std::optional<std::string> read_scalar_string(hid_t obj, const char* name, const std::string& where,
                                              const std::string& file) {
  auto v = read_string_attribute(obj, name, where, file, false);
  if (!v) return std::nullopt;
  if (v->size() != 1) fail(file, where, "expected one string, got " + std::to_string(v->size()));
  return v->front();
}

// The attributes of /particles and of the root group (docs/scene.md), shared by the whole-set
// writer and the streaming one.
void write_particle_attributes(hid_t f, hid_t g, const ParticleFileMeta& meta,
                               const std::string& file) {
  Handle st = vlen_string_type(file);
  std::vector<const char*> names;
  for (const auto& s : meta.type_names) names.push_back(s.c_str());
  write_attribute(g, "type_names", "/particles@type_names", st.get(), st.get(),
                  {static_cast<hsize_t>(names.size())}, names.data(), file);
  write_attribute(g, "box_lo", "/particles@box_lo", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3},
                  meta.box.lo.data(), file);
  write_attribute(g, "box_hi", "/particles@box_hi", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3},
                  meta.box.hi.data(), file);
  const std::array<std::int32_t, 3> periodic{
      meta.box.periodic[0] ? 1 : 0, meta.box.periodic[1] ? 1 : 0, meta.box.periodic[2] ? 1 : 0};
  write_attribute(g, "periodic", "/particles@periodic", H5T_STD_I32LE, H5T_NATIVE_INT32, {3},
                  periodic.data(), file);
  write_attribute(g, "step", "/particles@step", H5T_STD_U64LE, H5T_NATIVE_UINT64, {}, &meta.step,
                  file);
  write_attribute(g, "time", "/particles@time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}, &meta.time,
                  file);
  write_string_attribute(f, "mesorock_version", "/@mesorock_version", kVersion, file);
  write_string_attribute(f, "git_commit", "/@git_commit", kGitCommit, file);
  write_string_attribute(f, "created_by", "/@created_by", meta.created_by, file);
  write_string_attribute(f, "provenance", "/@provenance", meta.provenance_json, file);
  write_string_attribute(f, "length_unit", "/@length_unit", meta.length_unit, file);
}

// Every type indexes type_names and every position and velocity is finite (IoError otherwise).
void check_particles_writable(const ParticleSet& p, std::size_t ntypes_u, const std::string& file) {
  const size_t n = p.size();
  if (p.y.size() != n || p.z.size() != n || p.vx.size() != n || p.vy.size() != n ||
      p.vz.size() != n || p.type.size() != n || p.id.size() != n)
    fail(file, "", "cannot write: particle arrays have different lengths");
  const auto ntypes = static_cast<std::int64_t>(ntypes_u);
  for (size_t i = 0; i < n; ++i) {
    if (p.type[i] < 0 || p.type[i] >= ntypes)
      fail(file, "/particles/type",
           "cannot write: particle " + std::to_string(p.id[i]) + " has type " +
               std::to_string(p.type[i]) + ", but there are " + std::to_string(ntypes) +
               " type names");
    for (double v : {p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i]})
      if (!std::isfinite(v))
        fail(file, "/particles",
             "cannot write: particle " + std::to_string(p.id[i]) +
                 " has a non-finite position or velocity");
  }
}

}  // namespace

void skip_hdf5_exit_cleanup() {
  H5dont_atexit();
}

void write_particle_file(const fs::path& path, const ParticleSet& p, const ParticleFileMeta& meta) {
  silence_hdf5_errors();
  const std::string file = path.string();
  const size_t n = p.size();
  check_particles_writable(p, meta.type_names.size(), file);

  std::vector<double> pos(3 * n), vel(3 * n);
  for (size_t i = 0; i < n; ++i) {
    pos[3 * i] = p.x[i];
    pos[3 * i + 1] = p.y[i];
    pos[3 * i + 2] = p.z[i];
    vel[3 * i] = p.vx[i];
    vel[3 * i + 1] = p.vy[i];
    vel[3 * i + 2] = p.vz[i];
  }

  write_atomically(path, [&](const fs::path& tmp) {
    // STRONG close degree: closing the file closes every object in it, so H5Fclose really
    // flushes and closes.
    Handle f = create_file(tmp, file);
    {
      Handle g = checked(H5Gcreate2(f.get(), "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                         H5Gclose, file, "/particles", "cannot create group");
      const hsize_t hn = static_cast<hsize_t>(n);
      write_dataset(g.get(), "position", "/particles/position", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                    {hn, 3}, pos.data(), file);
      write_dataset(g.get(), "velocity", "/particles/velocity", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                    {hn, 3}, vel.data(), file);
      write_dataset(g.get(), "type", "/particles/type", H5T_STD_I32LE, H5T_NATIVE_INT32, {hn},
                    p.type.data(), file);
      write_dataset(g.get(), "id", "/particles/id", H5T_STD_I64LE, H5T_NATIVE_INT64, {hn},
                    p.id.data(), file);

      write_particle_attributes(f.get(), g.get(), meta, file);
    }
    if (!f.close()) fail(file, "", "cannot close file (write failed)");
  });
}

namespace {

// A particle file open for reading: the file and its /particles group.
struct OpenParticleFile {
  std::string file;  // the path, for messages
  Handle f, g;
};
OpenParticleFile open_particle_file(const fs::path& path) {
  silence_hdf5_errors();
  OpenParticleFile o;
  o.file = path.string();
  o.f = open_file_for_reading(path, o.file);
  if (H5Lexists(o.f.get(), "particles", H5P_DEFAULT) <= 0) fail(o.file, "/particles", "missing");
  o.g = checked(H5Gopen2(o.f.get(), "particles", H5P_DEFAULT), H5Gclose, o.file, "/particles",
                "not a group");
  return o;
}

// The attributes of an open particle file (f the file, g its /particles group), checked.
ParticleFileMeta read_meta(hid_t f, hid_t g, const std::string& file) {
  ParticleFileMeta meta;
  meta.type_names = *read_string_attribute(g, "type_names", "/particles@type_names", file, true);
  {
    std::set<std::string> seen;
    for (const auto& s : meta.type_names) {
      if (s.empty()) fail(file, "/particles@type_names", "empty type name");
      if (!seen.insert(s).second)
        fail(file, "/particles@type_names", "duplicate type name \"" + s + "\"");
    }
  }
  const auto lo = *read_numeric_attribute<double>(g, "box_lo", "/particles@box_lo",
                                                  H5T_NATIVE_DOUBLE, H5T_FLOAT, 3, file, true);
  const auto hi = *read_numeric_attribute<double>(g, "box_hi", "/particles@box_hi",
                                                  H5T_NATIVE_DOUBLE, H5T_FLOAT, 3, file, true);
  const auto per = *read_numeric_attribute<std::int32_t>(
      g, "periodic", "/particles@periodic", H5T_NATIVE_INT32, H5T_INTEGER, 3, file, true);
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]))
      fail(file, "/particles@box_lo", "box bounds must be finite");
    if (!(hi[a] > lo[a]))
      fail(file, "/particles@box_hi",
           "box_hi must exceed box_lo on every axis (axis " + std::to_string(a) + ": " +
               number_text(hi[a]) + " <= " + number_text(lo[a]) + ")");
    meta.box.lo[a] = lo[a];
    meta.box.hi[a] = hi[a];
    meta.box.periodic[a] = per[a] != 0;
  }
  if (auto s = read_numeric_attribute<std::uint64_t>(
          g, "step", "/particles@step", H5T_NATIVE_UINT64, H5T_INTEGER, 1, file, false))
    meta.step = s->front();
  if (auto t = read_numeric_attribute<double>(g, "time", "/particles@time", H5T_NATIVE_DOUBLE,
                                              H5T_FLOAT, 1, file, false)) {
    if (!std::isfinite(t->front())) fail(file, "/particles@time", "must be finite");
    meta.time = t->front();
  }
  if (auto s = read_scalar_string(f, "created_by", "/@created_by", file)) meta.created_by = *s;
  if (auto s = read_scalar_string(f, "provenance", "/@provenance", file)) meta.provenance_json = *s;
  if (auto s = read_scalar_string(f, "length_unit", "/@length_unit", file)) meta.length_unit = *s;
  if (auto s = read_scalar_string(f, "mesorock_version", "/@mesorock_version", file))
    meta.mesorock_version = *s;
  if (auto s = read_scalar_string(f, "git_commit", "/@git_commit", file)) meta.git_commit = *s;
  return meta;
}

}  // namespace

ParticleSet read_particle_file(const fs::path& path, ParticleFileMeta* meta_out) {
  const OpenParticleFile o = open_particle_file(path);
  const std::string& file = o.file;
  const Handle &f = o.f, &g = o.g;
  ParticleFileMeta meta = read_meta(f.get(), g.get(), file);

  hsize_t n = 0;
  const auto pos = read_dataset<double>(g.get(), "position", H5T_NATIVE_DOUBLE, H5T_FLOAT, 3,
                                        std::nullopt, file, &n);
  const auto vel =
      read_dataset<double>(g.get(), "velocity", H5T_NATIVE_DOUBLE, H5T_FLOAT, 3, n, file, nullptr);
  const auto type = read_dataset<std::int32_t>(g.get(), "type", H5T_NATIVE_INT32, H5T_INTEGER, 0, n,
                                               file, nullptr);
  const auto id =
      read_dataset<std::int64_t>(g.get(), "id", H5T_NATIVE_INT64, H5T_INTEGER, 0, n, file, nullptr);

  const auto ntypes = static_cast<std::int64_t>(meta.type_names.size());
  ParticleSet p;
  p.reserve(static_cast<size_t>(n));
  for (size_t i = 0; i < static_cast<size_t>(n); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(pos[3 * i + static_cast<size_t>(c)]))
        fail(file, "/particles/position", "entry " + std::to_string(i) + " is not finite");
      if (!std::isfinite(vel[3 * i + static_cast<size_t>(c)]))
        fail(file, "/particles/velocity", "entry " + std::to_string(i) + " is not finite");
    }
    if (type[i] < 0 || type[i] >= ntypes)
      fail(file, "/particles/type",
           "entry " + std::to_string(i) + " is " + std::to_string(type[i]) + ", outside 0.." +
               std::to_string(ntypes - 1) + " (" + std::to_string(ntypes) +
               " names in type_names)");
    p.add(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], vel[3 * i], vel[3 * i + 1], vel[3 * i + 2],
          type[i], id[i]);
  }
  {
    std::vector<std::int64_t> sorted(id);
    std::sort(sorted.begin(), sorted.end());
    const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
    if (dup != sorted.end()) fail(file, "/particles/id", "duplicate id " + std::to_string(*dup));
  }
  if (meta_out) *meta_out = std::move(meta);
  return p;
}

ParticleFileMeta read_particle_file_meta(const fs::path& path) {
  const OpenParticleFile o = open_particle_file(path);
  return read_meta(o.f.get(), o.g.get(), o.file);
}

std::size_t read_particle_file_count(const fs::path& path) {
  const OpenParticleFile o = open_particle_file(path);
  const std::string& file = o.file;
  const Handle& g = o.g;
  const std::string where = "/particles/position";
  Handle ds = open_dataset(g.get(), "position", where, file);
  Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, where, "cannot read dataspace");
  const auto dims = extent(space.get(), file, where);
  if (dims.size() != 2 || dims[1] != 3)
    fail(file, where, "expected shape [N,3], got " + dims_text(dims));
  check_declared_size(ds.get(), dims, sizeof(double), file, where);
  return static_cast<std::size_t>(dims[0]);
}

void write_particle_xdmf(const fs::path& xmf, const fs::path& h5, std::size_t n,
                         std::optional<double> time) {
  // The data path is relative to the .xmf's folder, so the pair can be moved together.
  const std::string data = xml_escape(xdmf_data_path(xmf, h5));
  const std::string N = std::to_string(n);

  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n"
    << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
    << "  <Domain>\n"
    << "    <Grid Name=\"particles\" GridType=\"Uniform\">\n";
  if (time) x << "      <Time Value=\"" << number_text(*time) << "\"/>\n";
  x << "      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << N
    << "\" NodesPerElement=\"1\"/>\n"
    << "      <Geometry GeometryType=\"XYZ\">\n"
    << "        <DataItem Dimensions=\"" << N
    << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << data
    << ":/particles/position</DataItem>\n"
    << "      </Geometry>\n"
    << "      <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">\n"
    << "        <DataItem Dimensions=\"" << N
    << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << data
    << ":/particles/velocity</DataItem>\n"
    << "      </Attribute>\n"
    << "      <Attribute Name=\"type\" AttributeType=\"Scalar\" Center=\"Node\">\n"
    << "        <DataItem Dimensions=\"" << N
    << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << data
    << ":/particles/type</DataItem>\n"
    << "      </Attribute>\n"
    << "      <Attribute Name=\"id\" AttributeType=\"Scalar\" Center=\"Node\">\n"
    << "        <DataItem Dimensions=\"" << N
    << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << data
    << ":/particles/id</DataItem>\n"
    << "      </Attribute>\n"
    << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  write_text_atomically(xmf, x.str());
}

// ---------------------------------------------------------------------------------------------
// Streaming writer

struct ParticleFileWriter::Impl {
  fs::path target, tmp;
  std::string file;
  ParticleFileMeta meta;
  Handle f, g;
  Handle position, velocity, type, id;
  hsize_t rows = 0;
  bool committed = false;
  std::vector<double> xyz;  // interleaving buffer, kept between appends

  // An empty dataset of `cols` columns (0: one-dimensional) that grows along its first axis.
  Handle growing(const char* name, hid_t file_type, hsize_t cols) {
    const std::string where = std::string("/particles/") + name;
    const int rank = cols == 0 ? 1 : 2;
    const hsize_t dims[2] = {0, cols}, max[2] = {H5S_UNLIMITED, cols};
    // 64 Ki rows per chunk: large enough that appends are a few big writes.
    const hsize_t chunk[2] = {65536, cols};
    Handle space = checked(H5Screate_simple(rank, dims, max), H5Sclose, file, where,
                           "cannot create dataspace");
    Handle dcpl =
        checked(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, file, where, "cannot create dataset");
    check(H5Pset_chunk(dcpl.get(), rank, chunk), file, where, "cannot create dataset");
    return checked(
        H5Dcreate2(g.get(), name, file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
        H5Dclose, file, where, "cannot create dataset");
  }

  void extend_and_write(const Handle& ds, const char* name, hid_t mem_type, hsize_t cols,
                        hsize_t count, const void* data) {
    const std::string where = std::string("/particles/") + name;
    const int rank = cols == 0 ? 1 : 2;
    const hsize_t new_dims[2] = {rows + count, cols};
    check(H5Dset_extent(ds.get(), new_dims), file, where, "write failed");
    Handle space = checked(H5Dget_space(ds.get()), H5Sclose, file, where, "write failed");
    const hsize_t start[2] = {rows, 0}, block[2] = {count, cols};
    check(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, block, nullptr), file,
          where, "write failed");
    Handle mem =
        checked(H5Screate_simple(rank, block, nullptr), H5Sclose, file, where, "write failed");
    check(H5Dwrite(ds.get(), mem_type, mem.get(), space.get(), H5P_DEFAULT, data), file, where,
          "write failed");
  }
};

ParticleFileWriter::ParticleFileWriter(const fs::path& path, ParticleFileMeta meta)
    : impl_(std::make_unique<Impl>()) {
  silence_hdf5_errors();
  Impl& m = *impl_;
  m.target = path;
  m.tmp = temporary_path_for(path);
  m.file = path.string();
  m.meta = std::move(meta);
  m.f = create_file(m.tmp, m.file);
  m.g = checked(H5Gcreate2(m.f.get(), "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                m.file, "/particles", "cannot create group");
  m.position = m.growing("position", H5T_IEEE_F64LE, 3);
  m.velocity = m.growing("velocity", H5T_IEEE_F64LE, 3);
  m.type = m.growing("type", H5T_STD_I32LE, 0);
  m.id = m.growing("id", H5T_STD_I64LE, 0);
}

ParticleFileWriter::~ParticleFileWriter() {
  if (!impl_ || impl_->committed) return;
  impl_->position = Handle();
  impl_->velocity = Handle();
  impl_->type = Handle();
  impl_->id = Handle();
  impl_->g = Handle();
  impl_->f = Handle();
  std::error_code ignored;
  fs::remove(impl_->tmp, ignored);
}

std::size_t ParticleFileWriter::size() const {
  return static_cast<std::size_t>(impl_->rows);
}

void ParticleFileWriter::append(const ParticleSet& p) {
  Impl& m = *impl_;
  if (m.committed) throw std::logic_error("ParticleFileWriter::append after commit");
  check_particles_writable(p, m.meta.type_names.size(), m.file);
  const size_t n = p.size();
  if (n == 0) return;
  std::vector<double>& xyz = m.xyz;
  xyz.resize(3 * n);
  const auto interleave = [&](const std::vector<double>& a, const std::vector<double>& b,
                              const std::vector<double>& c) {
    for (size_t i = 0; i < n; ++i) {
      xyz[3 * i] = a[i];
      xyz[3 * i + 1] = b[i];
      xyz[3 * i + 2] = c[i];
    }
  };
  const hsize_t count = static_cast<hsize_t>(n);
  interleave(p.x, p.y, p.z);
  m.extend_and_write(m.position, "position", H5T_NATIVE_DOUBLE, 3, count, xyz.data());
  interleave(p.vx, p.vy, p.vz);
  m.extend_and_write(m.velocity, "velocity", H5T_NATIVE_DOUBLE, 3, count, xyz.data());
  m.extend_and_write(m.type, "type", H5T_NATIVE_INT32, 0, count, p.type.data());
  m.extend_and_write(m.id, "id", H5T_NATIVE_INT64, 0, count, p.id.data());
  m.rows += count;
}

void ParticleFileWriter::commit() {
  Impl& m = *impl_;
  if (m.committed) return;
  for (Handle* h : {&m.position, &m.velocity, &m.type, &m.id})
    if (!h->close()) fail(m.file, "/particles", "write failed");
  write_particle_attributes(m.f.get(), m.g.get(), m.meta, m.file);
  m.g.close();
  if (!m.f.close()) fail(m.file, "", "cannot close file (write failed)");
  std::error_code ec;
  fs::rename(m.tmp, m.target, ec);
  if (ec) fail(m.file, "", "cannot rename temporary file: " + ec.message());
  m.committed = true;
}

}  // namespace mesorock::sim
