#pragma once
// Fuzz harnesses of the image loaders (voxel/load.h and the format readers). A loader must return
// a volume or refuse the input with a mesorock::Error (IoError, ConfigError, LimitError) whose
// message is one line; any other exception, a crash, a sanitizer report or a hang is a defect.
// The libFuzzer targets (tests/fuzz/fuzz_*.cpp) and the normal build's replay of the crashes found
// (tests/unit/voxel/test_fuzz_regressions.cpp) both call these.
#include <hdf5.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuzz_bytes.h"
#include "mesorock/errors.h"
#include "voxel/hdf5_io.h"
#include "voxel/load.h"
#include "voxel/npy_io.h"
#include "voxel/raw_io.h"
#include "voxel/tiff_io.h"

namespace mesorock::fuzz {

// Small enough that no input can make a loader take much memory.
inline voxel::ReadLimits fuzz_limits() {
  voxel::ReadLimits l;
  l.max_bytes = std::size_t(16) << 20;
  return l;
}

// The message of the last refusal ("" after a successful load): fuzz_make_seeds checks with it
// that every seed loads.
inline std::string& last_refusal() {
  static std::string message;
  return message;
}

// Runs a loader: a typed refusal is fine if its message is one line.
template <class Load>
void expect_load_or_refusal(Load&& load) {
  last_refusal().clear();
  try {
    const voxel::Volume v = load();
    if (!v.empty() && v.byte_size() > fuzz_limits().max_bytes)
      throw std::logic_error("loader returned more than the byte limit");
  } catch (const Error& e) {
    const std::string m = e.what();
    last_refusal() = m.empty() ? "(empty message)" : m;
    if (m.find('\n') != std::string::npos)
      throw std::logic_error("error message spans several lines: " + m);
  }
}

// A TIFF file (first byte even), or a folder of two slices split at the middle (odd).
inline void fuzz_tiff(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const bool folder = data[0] & 1u;
  ++data;
  --size;
  if (!folder) {
    const fs::path p = write_scratch("input.tif", data, size);
    expect_load_or_refusal([&] { return voxel::read_tiff_file(p, fuzz_limits()); });
    expect_load_or_refusal([&] {
      return voxel::load_volume(p, [] {
        voxel::LoadOptions o;
        o.limits = fuzz_limits();
        return o;
      }());
    });
    return;
  }
  const fs::path dir = scratch_dir() / "slices";
  fs::create_directories(dir);
  write_scratch("slices/slice_0.tif", data, size / 2);
  write_scratch("slices/slice_1.tif", data + size / 2, size - size / 2);
  expect_load_or_refusal([&] { return voxel::read_tiff_folder(dir, fuzz_limits()); });
}

inline void fuzz_npy(const std::uint8_t* data, std::size_t size) {
  const fs::path p = write_scratch("input.npy", data, size);
  expect_load_or_refusal([&] { return voxel::read_npy(p, fuzz_limits()); });
}

inline void fuzz_npz(const std::uint8_t* data, std::size_t size) {
  const fs::path p = write_scratch("input.npz", data, size);
  expect_load_or_refusal([&] { return voxel::read_npz(p, "", fuzz_limits()); });
  expect_load_or_refusal([&] { return voxel::read_npz(p, "im", fuzz_limits()); });
  try {
    (void)voxel::list_npz_arrays(p);
  } catch (const Error&) {
  }
}

// A MetaImage header (with inline data when it says LOCAL). A companion data file "data.raw"
// (4 KiB) and, after a "\n@json\n" line in the input, a sidecar "input.json" are provided too.
inline void fuzz_mhd(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::uint8_t> companion = [] {
    std::vector<std::uint8_t> v(4096);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::uint8_t>(i * 7 + 3);
    return v;
  }();
  write_scratch("data.raw", companion.data(), companion.size());
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string marker = "\n@json\n";
  const std::size_t at = text.find(marker);
  const std::string header = at == std::string::npos ? text : text.substr(0, at);
  const std::string sidecar = at == std::string::npos ? "" : text.substr(at + marker.size());
  const fs::path json = scratch_dir() / "input.json";
  std::error_code ec;
  fs::remove(json, ec);
  if (at != std::string::npos) write_scratch("input.json", sidecar.data(), sidecar.size());
  const fs::path p = write_scratch("input.mhd", header.data(), header.size());
  expect_load_or_refusal([&] { return voxel::read_mhd(p, fuzz_limits()); });
}

// Headerless raw: the first 6 bytes choose shape, dtype, byte order and header bytes.
inline void fuzz_raw(const std::uint8_t* data, std::size_t size) {
  ByteReader r(data, size);
  voxel::RawOptions o;
  o.shape = {r.pick(17), r.pick(17), r.pick(17)};
  o.dtype = static_cast<voxel::DType>(r.pick(6));  // 5 is out of range on purpose
  o.big_endian = r.flag();
  o.header_bytes = r.pick(16);
  const fs::path p = write_scratch("input.raw", r.rest(), r.left());
  if (static_cast<int>(o.dtype) > 4) return;  // not a DType a caller can build
  expect_load_or_refusal([&] { return voxel::read_raw(p, o, fuzz_limits()); });
}

// HDF5 through the library's own writer: the fuzz bytes choose a file's datasets (rank, extent,
// element type, layout, a group), their attributes (spacing, unit, element_size_um with odd
// types, lengths and values) and which dataset to ask for. Raw bytes would mostly exercise the
// HDF5 library's own parser, which is not ours to fix; this exercises what mesorock does with
// whatever a valid file can hold.
inline hid_t fuzz_hdf5_type(ByteReader& r) {
  switch (r.pick(12)) {
    case 0:
      return H5Tcopy(H5T_NATIVE_INT8);
    case 1:
      return H5Tcopy(H5T_NATIVE_UINT8);
    case 2:
      return H5Tcopy(H5T_NATIVE_UINT16);
    case 3:
      return H5Tcopy(H5T_NATIVE_INT16);
    case 4:
      return H5Tcopy(H5T_NATIVE_FLOAT);
    case 5:
      return H5Tcopy(H5T_NATIVE_DOUBLE);
    case 6:
      return H5Tcopy(H5T_NATIVE_INT32);
    case 7:
      return H5Tcopy(H5T_STD_U16BE);
    case 8:
      return H5Tcopy(H5T_IEEE_F32BE);
    case 9: {  // h5py's bool, or a two-member enum with other values
      hid_t t = H5Tenum_create(H5T_NATIVE_INT8);
      std::int8_t a = static_cast<std::int8_t>(r.flag() ? 0 : r.byte());
      std::int8_t b = static_cast<std::int8_t>(r.flag() ? 1 : r.byte());
      if (a == b) b = static_cast<std::int8_t>(a + 1);
      H5Tenum_insert(t, "FALSE", &a);
      H5Tenum_insert(t, "TRUE", &b);
      return t;
    }
    case 10: {
      hid_t t = H5Tcopy(H5T_C_S1);
      H5Tset_size(t, 1 + r.pick(8));
      return t;
    }
    default: {
      hid_t t = H5Tenum_create(H5T_NATIVE_UINT8);
      for (unsigned k = 0, n = r.pick(4); k < n; ++k) {
        const std::uint8_t v = static_cast<std::uint8_t>(k * 3 + 1);
        const std::string name = "M" + std::to_string(k);
        H5Tenum_insert(t, name.c_str(), &v);
      }
      return t;
    }
  }
}

inline void fuzz_hdf5_attribute(hid_t object, const char* name, ByteReader& r) {
  const unsigned kind = r.pick(4);  // 0 doubles, 1 fixed string, 2 variable string, 3 integers
  const hsize_t n = r.pick(5);
  hid_t space = n == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr);
  const std::size_t count = n == 0 ? 1 : static_cast<std::size_t>(n);
  if (kind == 0 || kind == 3) {
    std::vector<double> values(count);
    for (double& v : values) v = r.flag() ? r.real() : static_cast<double>(r.pick(9));
    const hid_t type = kind == 0 ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT32;
    hid_t a = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
    if (kind == 0) {
      H5Awrite(a, H5T_NATIVE_DOUBLE, values.data());
    } else {
      std::vector<std::int32_t> ints(count);
      for (std::size_t k = 0; k < count; ++k) ints[k] = static_cast<std::int32_t>(r.u32());
      H5Awrite(a, H5T_NATIVE_INT32, ints.data());
    }
    H5Aclose(a);
  } else {
    static const char* const words[] = {"um", "nm", "", "micron", "\xc2\xb5m", "voxel", "mm  "};
    hid_t type = H5Tcopy(H5T_C_S1);
    if (kind == 2) {
      H5Tset_size(type, H5T_VARIABLE);
      std::vector<const char*> texts(count);
      for (auto& t : texts) t = words[r.pick(7)];
      hid_t a = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(a, type, texts.data());
      H5Aclose(a);
    } else {
      const std::size_t width = 1 + r.pick(6);
      H5Tset_size(type, width);
      std::string buffer(width * count, '\0');
      for (char& c : buffer) c = static_cast<char>(r.byte());
      hid_t a = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(a, type, buffer.data());
      H5Aclose(a);
    }
    H5Tclose(type);
  }
  H5Sclose(space);
}

inline void fuzz_hdf5(const std::uint8_t* data, std::size_t size) {
  ByteReader r(data, size);
  const fs::path p = scratch_dir() / "input.h5";
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t file = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error("fuzz_hdf5: cannot create the scratch file");
  static const char* const names[] = {"/im", "/g/im", "/a", "/g/h/b"};
  const unsigned datasets = 1 + r.pick(3);
  for (unsigned d = 0; d < datasets; ++d) {
    const int rank = static_cast<int>(r.pick(5));  // 0 (scalar) .. 4
    hsize_t dims[4] = {1, 1, 1, 1};
    for (int k = 0; k < rank; ++k) dims[k] = r.pick(7);
    hid_t space = rank == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(rank, dims, nullptr);
    hid_t type = fuzz_hdf5_type(r);
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    bool chunked = rank > 0 && r.flag();
    for (int k = 0; k < rank && chunked; ++k) chunked = dims[k] > 0;
    if (chunked) {
      hsize_t chunk[4];
      for (int k = 0; k < rank; ++k) chunk[k] = 1 + r.pick(static_cast<unsigned>(dims[k]));
      H5Pset_chunk(dcpl, rank, chunk);
      if (r.flag()) H5Pset_deflate(dcpl, 1);
    }
    hid_t ds = H5Dcreate2(file, names[r.pick(4)], type, space, lcpl, dcpl, H5P_DEFAULT);
    if (ds >= 0) {
      const hssize_t points = H5Sget_simple_extent_npoints(space);
      std::vector<std::uint8_t> bytes(static_cast<std::size_t>(points > 0 ? points : 0) *
                                      H5Tget_size(type));
      for (auto& b : bytes) b = r.byte();
      if (H5Tget_class(type) != H5T_ENUM && !bytes.empty())
        H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data());
      for (const char* attribute : {"spacing", "unit", "element_size_um"})
        if (r.flag()) fuzz_hdf5_attribute(ds, attribute, r);
      H5Dclose(ds);
    }
    H5Pclose(dcpl);
    H5Pclose(lcpl);
    H5Tclose(type);
    H5Sclose(space);
  }
  H5Fclose(file);
  H5Eclear2(H5E_DEFAULT);
  static const char* const asked[] = {"", "/im", "/g/im", "/nowhere", "g/h/b"};
  const std::string dataset = asked[r.pick(5)];
  expect_load_or_refusal([&] { return voxel::read_hdf5(p, dataset, fuzz_limits()); });
}

}  // namespace mesorock::fuzz
