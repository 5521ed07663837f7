#pragma once
// Internal helpers shared by the HDF5 writers and readers of sim/ (particle_io.cpp, field_io.cpp):
// an owning handle for HDF5 identifiers, IoError messages of the form "<file>: <where>: <problem>",
// dataset/attribute writers, and the small text helpers the XDMF sidecars need.
// Not part of the public API: only sim/*.cpp and tiledb/database.cpp (tiledb depends on sim)
// include it.
#include <hdf5.h>

#include <charconv>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mesorock/errors.h"

namespace mesorock::sim::hdf5_util {

// HDF5 prints its error stack to stderr by default; our callers get IoError messages instead.
inline void silence_hdf5_errors() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

// Owns one HDF5 identifier (file, group, dataset, dataspace, datatype, attribute, property list).
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, -1)), closer_(o.closer_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, -1);
      closer_ = o.closer_;
    }
    return *this;
  }
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  // Closes now; returns false when the library reports a failure (e.g. a failed flush).
  bool close() {
    if (id_ < 0) return true;
    const herr_t r = closer_(std::exchange(id_, -1));
    return r >= 0;
  }

 private:
  void reset() {
    if (id_ >= 0 && closer_) closer_(id_);
    id_ = -1;
  }
  hid_t id_ = -1;
  Closer closer_ = nullptr;
};

// Messages: "<file>: <where>: <problem>".
[[noreturn]] inline void fail(const std::string& file, const std::string& where,
                              const std::string& problem) {
  throw IoError(file + ": " + (where.empty() ? "" : where + ": ") + problem);
}

inline void check(herr_t status, const std::string& file, const std::string& where,
                  const std::string& problem) {
  if (status < 0) fail(file, where, problem);
}

inline Handle checked(hid_t id, Handle::Closer closer, const std::string& file,
                      const std::string& where, const std::string& problem) {
  if (id < 0) fail(file, where, problem);
  return Handle(id, closer);
}

// ---------------------------------------------------------------------------------------------
// Writing

// Creates (truncates) `tmp` for writing; errors name `file` (the final target). The file access
// list uses H5F_CLOSE_STRONG: closing the file closes every object in it, so a successful
// Handle::close() on the returned file really flushed and closed it.
inline Handle create_file(const std::filesystem::path& tmp, const std::string& file) {
  Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "", "cannot create file");
  check(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), file, "", "cannot create file");
  return checked(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose, file, "",
                 "cannot create file");
}

inline Handle create_group(hid_t parent, const char* name, const std::string& where,
                           const std::string& file) {
  return checked(H5Gcreate2(parent, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, file,
                 where, "cannot create group");
}

inline Handle simple_space(const std::vector<hsize_t>& dims, const std::string& file,
                           const std::string& where) {
  return checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose,
                 file, where, "cannot create dataspace");
}

inline Handle vlen_string_type(const std::string& file) {
  Handle t = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, "", "cannot create string type");
  check(H5Tset_size(t.get(), H5T_VARIABLE), file, "", "cannot create string type");
  check(H5Tset_cset(t.get(), H5T_CSET_UTF8), file, "", "cannot create string type");
  return t;
}

// Creates dataset `name` in `group` with the given shape ({} = scalar) and writes `data`.
// Returns the open dataset (for attributes); it is closed, with its status checked, by the
// caller's file close (H5F_CLOSE_STRONG) or explicitly.
inline Handle create_dataset(hid_t group, const char* name, const std::string& where,
                             hid_t file_type, hid_t mem_type, const std::vector<hsize_t>& dims,
                             const void* data, const std::string& file) {
  Handle space = dims.empty() ? checked(H5Screate(H5S_SCALAR), H5Sclose, file, where,
                                        "cannot create dataspace")
                              : simple_space(dims, file, where);
  Handle ds = checked(
      H5Dcreate2(group, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose, file, where, "cannot create dataset");
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  if (total > 0)
    check(H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), file, where,
          "write failed");
  return ds;
}

inline void write_dataset(hid_t group, const char* name, const std::string& where, hid_t file_type,
                          hid_t mem_type, const std::vector<hsize_t>& dims, const void* data,
                          const std::string& file) {
  Handle ds = create_dataset(group, name, where, file_type, mem_type, dims, data, file);
  if (!ds.close()) fail(file, where, "write failed");
}

// `dims` empty: a scalar attribute.
inline void write_attribute(hid_t obj, const char* name, const std::string& where, hid_t file_type,
                            hid_t mem_type, const std::vector<hsize_t>& dims, const void* data,
                            const std::string& file) {
  Handle space = dims.empty() ? checked(H5Screate(H5S_SCALAR), H5Sclose, file, where,
                                        "cannot create dataspace")
                              : simple_space(dims, file, where);
  Handle attr = checked(H5Acreate2(obj, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                        H5Aclose, file, where, "cannot create attribute");
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  if (total > 0) check(H5Awrite(attr.get(), mem_type, data), file, where, "cannot write attribute");
}

// A scalar variable-length UTF-8 string attribute.
inline void write_string_attribute(hid_t obj, const char* name, const std::string& where,
                                   const std::string& value, const std::string& file) {
  Handle t = vlen_string_type(file);
  const char* ptr = value.c_str();
  write_attribute(obj, name, where, t.get(), t.get(), {}, &ptr, file);
}

// ---------------------------------------------------------------------------------------------
// Reading

// Opens `path` read-only with the STRONG close degree; IoError naming `file` when it is missing,
// not a regular file, or not HDF5.
inline Handle open_file_for_reading(const std::filesystem::path& path, const std::string& file) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(file, "", "no such file");
  if (!std::filesystem::is_regular_file(path, ec)) fail(file, "", "not a regular file");
  Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "", "cannot open file");
  check(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), file, "", "cannot open file");
  return checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose, file, "",
                 "cannot open as an HDF5 file (not HDF5, unreadable or damaged)");
}

inline std::string dims_text(const std::vector<hsize_t>& dims) {
  std::string s = "[";
  for (size_t i = 0; i < dims.size(); ++i) s += (i ? "," : "") + std::to_string(dims[i]);
  return s + "]";
}

inline std::vector<hsize_t> extent(hid_t space, const std::string& file, const std::string& where) {
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) fail(file, where, "cannot read dataspace");
  std::vector<hsize_t> dims(static_cast<size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0)
    fail(file, where, "cannot read dataspace");
  return dims;
}

// A dataset's declared size, checked before anything is allocated for it: a forged extent (1e12
// or 2^62 rows) used to reach std::vector ("out of memory", or "cannot create std::vector larger
// than max_size()"). The file bounds it: deflate, the only filter our writers use, packs at most
// 1032:1, so no dataset of a file holds more than 1032 times the file's size (plus 1 MiB).
inline void check_declared_size(hid_t ds, const std::vector<hsize_t>& dims,
                                std::size_t element_bytes, const std::string& file,
                                const std::string& where) {
  double bytes = static_cast<double>(element_bytes);
  for (hsize_t d : dims) bytes *= static_cast<double>(d);
  hsize_t file_bytes = 0;
  const hid_t f = H5Iget_file_id(ds);
  if (f >= 0) {
    if (H5Fget_filesize(f, &file_bytes) < 0) file_bytes = 0;
    H5Fclose(f);
  }
  if (bytes > 1032.0 * static_cast<double>(file_bytes) + 1048576.0) {
    std::ostringstream s;
    s << "declares " << dims_text(dims) << " (" << bytes << " bytes), more than the " << file_bytes
      << "-byte file can hold";
    fail(file, where, s.str());
  }
}

inline const char* class_name(H5T_class_t c) {
  switch (c) {
    case H5T_INTEGER:
      return "integer";
    case H5T_FLOAT:
      return "floating-point";
    case H5T_STRING:
      return "string";
    default:
      return "non-numeric";
  }
}

// ---------------------------------------------------------------------------------------------
// Text

// Text that reads back to the same double (17 significant digits).
inline std::string number_text(double v) {
  std::ostringstream s;
  s << std::setprecision(17) << v;
  return s.str();
}

// The shortest text that reads back to the same double ("0.1", "298.15", "1e-09").
inline std::string shortest_text(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

inline std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// The path of `h5` as an XDMF sidecar at `xmf` should name it: relative to the .xmf's folder (so
// the pair can be moved together), or absolute when no relative path exists. Not XML-escaped.
inline std::string xdmf_data_path(const std::filesystem::path& xmf,
                                  const std::filesystem::path& h5) {
  namespace fs = std::filesystem;
  const fs::path xmf_dir = fs::absolute(xmf).parent_path().lexically_normal();
  const fs::path h5_abs = fs::absolute(h5).lexically_normal();
  fs::path rel = h5_abs.lexically_relative(xmf_dir);
  if (rel.empty()) rel = h5_abs;
  return rel.generic_string();
}

}  // namespace mesorock::sim::hdf5_util
