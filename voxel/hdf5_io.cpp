#include "voxel/hdf5_io.h"

#include <hdf5.h>

#include <cstring>
#include <sstream>

#include "mesorock/errors.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {
namespace {

// HDF5 prints its error stack to stderr by default. While we call it, printing is off and the
// innermost message (the cause, e.g. "truncated file") becomes the IoError text.
class QuietHdf5 {
 public:
  QuietHdf5() {
    H5Eget_auto2(H5E_DEFAULT, &old_func_, &old_data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, old_func_, old_data_); }
  QuietHdf5(const QuietHdf5&) = delete;
  QuietHdf5& operator=(const QuietHdf5&) = delete;

 private:
  H5E_auto2_t old_func_ = nullptr;
  void* old_data_ = nullptr;
};

herr_t first_error(unsigned n, const H5E_error2_t* e, void* data) {
  auto* out = static_cast<std::string*>(data);
  if (n == 0 && e->desc) *out = e->desc;
  return 0;
}

std::string hdf5_error() {
  std::string message;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, first_error, &message);
  H5Eclear2(H5E_DEFAULT);
  return message.empty() ? "HDF5 gave no detail" : message;
}

class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  void reset(hid_t id) {
    if (id_ >= 0) close_(id_);
    id_ = id;
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct DatasetList {
  std::vector<std::string> names;
};

herr_t collect_dataset(hid_t group, const char* name, const H5L_info_t* info, void* data) {
  if (info->type != H5L_TYPE_HARD) return 0;
  // Opening a group as a dataset fails quietly (QuietHdf5 is active): that is the type test.
  Handle ds(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) return 0;
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank == 2 || rank == 3)
    static_cast<DatasetList*>(data)->names.push_back("/" + std::string(name));
  return 0;
}

std::vector<std::string> datasets_in(hid_t file) {
  DatasetList list;
  H5Lvisit(file, H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &list);
  H5Eclear2(H5E_DEFAULT);
  return list.names;
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < 8; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > 8) s += ", ...";
  return s.empty() ? "none" : s;
}

bool read_double_attribute(hid_t object, const char* name, std::vector<double>* values) {
  if (H5Aexists(object, name) <= 0) return false;
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n <= 0 || n > 16) return false;
  values->assign(static_cast<std::size_t>(n), 0.0);
  return H5Aread(attr.get(), H5T_NATIVE_DOUBLE, values->data()) >= 0;
}

// Reads a string attribute holding exactly one string (scalar or one element); anything else is
// not a usable value: an array of strings would not fit the one-string buffers read into below.
bool read_string_attribute(hid_t object, const char* name, std::string* value) {
  if (H5Aexists(object, name) <= 0) return false;
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING) return false;
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  if (H5Sget_simple_extent_npoints(space.get()) != 1) return false;
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle memory(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(memory.get(), H5T_VARIABLE);
    H5Tset_cset(memory.get(), H5Tget_cset(type.get()));
    char* text = nullptr;
    if (H5Aread(attr.get(), memory.get(), &text) < 0 || !text) return false;
    *value = text;
    H5free_memory(text);
    return true;
  }
  const std::size_t size = H5Tget_size(type.get());
  std::string buffer(size, '\0');
  if (H5Aread(attr.get(), type.get(), buffer.data()) < 0) return false;
  *value = buffer.c_str();
  return true;
}

}  // namespace

std::vector<std::string> list_hdf5_datasets(const fs::path& path) {
  QuietHdf5 quiet;
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw IoError(path.string() + ": cannot open as HDF5 (" + hdf5_error() + ")");
  return datasets_in(file.get());
}

Volume read_hdf5(const fs::path& path, const std::string& dataset, const ReadLimits& limits,
                 ReadReport* report) {
  const std::string name = path.string();
  const std::uint64_t file_size = file_size_or_throw(path);
  QuietHdf5 quiet;
  if (H5Fis_hdf5(path.c_str()) <= 0) throw IoError(name + ": not an HDF5 file");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw IoError(name + ": cannot open (" + hdf5_error() + ")");

  std::string chosen = dataset;
  if (chosen.empty()) {
    const std::vector<std::string> names = datasets_in(file.get());
    if (names.size() != 1) {
      throw ConfigError(name + ": holds " + std::to_string(names.size()) + " image datasets (" +
                        joined(names) + "); choose one with --dataset");
    }
    chosen = names.front();
  }
  Handle ds(H5Dopen2(file.get(), chosen.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) {
    H5Eclear2(H5E_DEFAULT);
    throw ConfigError(name + ": no dataset '" + chosen +
                      "' (image datasets: " + joined(datasets_in(file.get())) + ")");
  }
  const std::string what = name + ":" + chosen;

  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank != 2 && rank != 3) {
    throw IoError(what + ": has " + std::to_string(rank) + " dimensions; a volume needs 3");
  }
  hsize_t dims[3] = {1, 1, 1};
  H5Sget_simple_extent_dims(space.get(), rank == 3 ? dims : dims + 1, nullptr);
  const Shape shape{std::int64_t(dims[0]), std::int64_t(dims[1]), std::int64_t(dims[2])};

  Handle file_type(H5Dget_type(ds.get()), H5Tclose);
  const H5T_class_t type_class = H5Tget_class(file_type.get());
  const std::size_t type_size = H5Tget_size(file_type.get());
  DType dtype;
  hid_t memory_type = -1;
  Handle native_enum(-1, H5Tclose);
  if (type_class == H5T_INTEGER && type_size == 1) {
    const bool is_signed = H5Tget_sign(file_type.get()) == H5T_SGN_2;
    dtype = is_signed ? DType::kInt8 : DType::kUInt8;
    memory_type = is_signed ? H5T_NATIVE_INT8 : H5T_NATIVE_UINT8;
  } else if (type_class == H5T_INTEGER && type_size == 2 &&
             H5Tget_sign(file_type.get()) == H5T_SGN_NONE) {
    dtype = DType::kUInt16;
    memory_type = H5T_NATIVE_UINT16;
  } else if (type_class == H5T_FLOAT && type_size == 4) {
    dtype = DType::kFloat32;
    memory_type = H5T_NATIVE_FLOAT;
  } else if (type_class == H5T_ENUM && type_size == 1 && H5Tget_nmembers(file_type.get()) == 2) {
    dtype = DType::kBool;  // h5py's bool: enum {FALSE = 0, TRUE = 1} over int8
    native_enum.reset(H5Tget_native_type(file_type.get(), H5T_DIR_ASCEND));
    memory_type = native_enum.get();
  } else {
    std::ostringstream s;
    s << what << ": element type (class " << int(type_class) << ", " << type_size
      << " bytes) is not supported (int8, uint8, uint16, float32, bool)";
    throw IoError(s.str());
  }

  const std::size_t bytes = claimed_bytes(shape, dtype, what);
  Handle dcpl(H5Dget_create_plist(ds.get()), H5Pclose);
  if (H5Pget_layout(dcpl.get()) == H5D_CONTIGUOUS) {
    const haddr_t offset = H5Dget_offset(ds.get());
    if (offset != HADDR_UNDEF && (offset > file_size || bytes > file_size - offset)) {
      std::ostringstream s;
      s << what << ": shape " << shape.str() << " " << dtype_name(dtype) << " needs " << bytes
        << " bytes from offset " << offset << ", but the file has " << file_size
        << " bytes (truncated?)";
      throw IoError(s.str());
    }
  }
  checked_volume_bytes(shape, dtype, limits.max_bytes, what);

  Spacing spacing;
  std::vector<double> values;
  std::string unit;
  std::string spacing_source = "none";
  if (read_double_attribute(ds.get(), "spacing", &values) && values.size() == std::size_t(rank)) {
    spacing.dz = rank == 3 ? values[0] : 1.0;
    spacing.dy = values[rank - 2];
    spacing.dx = values[rank - 1];
    spacing.unit = read_string_attribute(ds.get(), "unit", &unit) ? normalize_unit(unit) : "";
    if (spacing.unit.empty()) {
      spacing.unit = "um";
      if (report)
        report->warnings.push_back(what +
                                   ": 'spacing' has no 'unit' holding one string; assuming um");
    }
    spacing_source = "metadata";
  } else if (read_double_attribute(ds.get(), "element_size_um", &values) &&
             values.size() == std::size_t(rank)) {
    spacing.dz = rank == 3 ? values[0] : 1.0;
    spacing.dy = values[rank - 2];
    spacing.dx = values[rank - 1];
    spacing.unit = "um";
    spacing_source = "metadata";
  }
  if (spacing_source == "metadata") validate_spacing(spacing, what);

  Volume volume(shape, dtype, spacing);
  if (H5Dread(ds.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, volume.bytes()) < 0) {
    throw IoError(what + ": cannot read (" + hdf5_error() + ")");
  }
  if (dtype == DType::kBool) {
    std::uint8_t* v = volume.data<std::uint8_t>();
    for (std::int64_t i = 0; i < volume.voxels(); ++i) v[i] = v[i] != 0;
  }
  if (report) {
    report->format = "hdf5";
    report->spacing_source = spacing_source;
  }
  return volume;
}

void write_hdf5(const Volume& volume, const fs::path& path, const std::string& dataset) {
  const std::string name = path.string();
  QuietHdf5 quiet;
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw IoError(name + ": cannot create (" + hdf5_error() + ")");
  const Shape& s = volume.shape();
  const hsize_t dims[3] = {hsize_t(s.nz), hsize_t(s.ny), hsize_t(s.nx)};
  Handle space(H5Screate_simple(3, dims, nullptr), H5Sclose);
  Handle type(-1, H5Tclose);
  hid_t memory_type;
  switch (volume.dtype()) {
    case DType::kBool: {
      type.reset(H5Tenum_create(H5T_NATIVE_INT8));
      std::int8_t no = 0, yes = 1;
      H5Tenum_insert(type.get(), "FALSE", &no);
      H5Tenum_insert(type.get(), "TRUE", &yes);
      memory_type = type.get();
      break;
    }
    case DType::kInt8:
      memory_type = H5T_NATIVE_INT8;
      break;
    case DType::kUInt8:
      memory_type = H5T_NATIVE_UINT8;
      break;
    case DType::kUInt16:
      memory_type = H5T_NATIVE_UINT16;
      break;
    default:
      memory_type = H5T_NATIVE_FLOAT;
      break;
  }
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle ds(H5Dcreate2(file.get(), dataset.c_str(), memory_type, space.get(), lcpl.get(),
                       H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!ds.ok())
    throw IoError(name + ": cannot create dataset " + dataset + " (" + hdf5_error() + ")");
  if (H5Dwrite(ds.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, volume.bytes()) < 0) {
    throw IoError(name + ": write failed (" + hdf5_error() + ")");
  }
  const double spacing[3] = {volume.spacing().dz, volume.spacing().dy, volume.spacing().dx};
  const hsize_t three = 3;
  Handle attr_space(H5Screate_simple(1, &three, nullptr), H5Sclose);
  Handle spacing_attr(H5Acreate2(ds.get(), "spacing", H5T_NATIVE_DOUBLE, attr_space.get(),
                                 H5P_DEFAULT, H5P_DEFAULT),
                      H5Aclose);
  H5Awrite(spacing_attr.get(), H5T_NATIVE_DOUBLE, spacing);
  Handle string_type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(string_type.get(), H5T_VARIABLE);
  H5Tset_cset(string_type.get(), H5T_CSET_UTF8);
  Handle scalar(H5Screate(H5S_SCALAR), H5Sclose);
  Handle unit_attr(
      H5Acreate2(ds.get(), "unit", string_type.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Aclose);
  const char* unit = volume.spacing().unit.c_str();
  if (H5Awrite(unit_attr.get(), string_type.get(), &unit) < 0) {
    throw IoError(name + ": cannot write attributes (" + hdf5_error() + ")");
  }
}

}  // namespace mesorock::voxel
