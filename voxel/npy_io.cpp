#include "voxel/npy_io.h"

#include <cstring>
#include <sstream>

#include "mesorock/errors.h"
#include "voxel/zip_reader.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {
namespace {

struct NpyHeader {
  DType dtype = DType::kUInt8;
  bool big_endian = false;
  bool fortran_order = false;
  std::vector<std::int64_t> shape;
  std::uint64_t header_bytes = 0;  // magic + length field + dict text
};

// The value text after 'key': in a Python dict literal such as
// {'descr': '<u2', 'fortran_order': False, 'shape': (200, 200, 200), }
std::string dict_value(const std::string& dict, const std::string& key, const std::string& what) {
  std::size_t pos = dict.find("'" + key + "'");
  if (pos == std::string::npos) pos = dict.find("\"" + key + "\"");
  if (pos == std::string::npos) throw IoError(what + ": npy header has no '" + key + "'");
  pos = dict.find(':', pos);
  if (pos == std::string::npos) throw IoError(what + ": malformed npy header");
  ++pos;
  while (pos < dict.size() && dict[pos] == ' ') ++pos;
  if (pos >= dict.size()) throw IoError(what + ": malformed npy header");
  std::size_t end;
  if (dict[pos] == '(') {
    end = dict.find(')', pos);
    if (end == std::string::npos) throw IoError(what + ": malformed npy shape");
    return dict.substr(pos, end - pos + 1);
  }
  if (dict[pos] == '\'' || dict[pos] == '"') {
    end = dict.find(dict[pos], pos + 1);
    if (end == std::string::npos) throw IoError(what + ": malformed npy header");
    return dict.substr(pos + 1, end - pos - 1);
  }
  end = dict.find_first_of(",}", pos);
  return trim(dict.substr(pos, end - pos));
}

NpyHeader parse_header(ByteSource& source, const std::string& what) {
  unsigned char prefix[10];
  if (source.remaining() < 10) throw IoError(what + ": too short to be an npy array");
  source.read(prefix, 10);
  if (std::memcmp(prefix, "\x93NUMPY", 6) != 0) throw IoError(what + ": not an npy array");
  const int major = prefix[6];
  std::uint64_t length;
  std::uint64_t fixed;
  if (major == 1) {
    length = prefix[8] | (prefix[9] << 8);
    fixed = 10;
  } else if (major == 2 || major == 3) {
    unsigned char more[2];
    source.read(more, 2);
    length = std::uint64_t(prefix[8]) | (std::uint64_t(prefix[9]) << 8) |
             (std::uint64_t(more[0]) << 16) | (std::uint64_t(more[1]) << 24);
    fixed = 12;
  } else {
    throw IoError(what + ": npy format version " + std::to_string(major) + " not supported");
  }
  if (length > 1u << 20 || length > source.remaining()) {
    throw IoError(what + ": corrupt npy header length");
  }
  std::string dict(static_cast<std::size_t>(length), '\0');
  source.read(dict.data(), dict.size());

  NpyHeader h;
  h.header_bytes = fixed + length;
  const std::string descr = dict_value(dict, "descr", what);
  const std::string kind = descr.size() == 3 ? descr.substr(1) : descr;
  const char order = descr.size() == 3 ? descr[0] : '|';
  if (kind == "b1") {
    h.dtype = DType::kBool;
  } else if (kind == "i1") {
    h.dtype = DType::kInt8;
  } else if (kind == "u1") {
    h.dtype = DType::kUInt8;
  } else if (kind == "u2" && order != '|') {
    h.dtype = DType::kUInt16;
  } else if (kind == "f4" && order != '|') {
    h.dtype = DType::kFloat32;
  } else {
    throw IoError(what + ": dtype '" + descr +
                  "' is not supported (bool, int8, uint8, uint16, float32)");
  }
  h.big_endian = order == '>';
  const std::string fortran = dict_value(dict, "fortran_order", what);
  if (fortran != "True" && fortran != "False") {
    throw IoError(what + ": malformed fortran_order '" + fortran + "'");
  }
  h.fortran_order = fortran == "True";
  std::string shape = dict_value(dict, "shape", what);
  if (shape.size() < 2 || shape.front() != '(' || shape.back() != ')')
    throw IoError(what + ": malformed npy shape '" + shape + "' (expected a tuple)");
  for (const std::string& part : split(shape.substr(1, shape.size() - 2), ',')) {
    const std::string t = trim(part);
    if (t.empty()) continue;
    char* end = nullptr;
    const long long v = std::strtoll(t.c_str(), &end, 10);
    if (*end != '\0' || v < 0) throw IoError(what + ": malformed npy shape " + shape);
    h.shape.push_back(v);
  }
  if (h.shape.size() != 2 && h.shape.size() != 3) {
    throw IoError(what + ": array has " + std::to_string(h.shape.size()) +
                  " dimensions; a volume needs 3 (or 2 for one slice)");
  }
  if (h.shape.size() == 2) h.shape.insert(h.shape.begin(), 1);
  return h;
}

void fix_bool(std::uint8_t* v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) v[i] = v[i] != 0;
}

Volume read_npy_stream(ByteSource& source, const std::string& what, const ReadLimits& limits) {
  const NpyHeader h = parse_header(source, what);
  const Shape shape{h.shape[0], h.shape[1], h.shape[2]};
  const std::size_t bytes = claimed_bytes(shape, h.dtype, what);
  if (source.remaining() != bytes) {
    std::ostringstream s;
    s << what << ": holds " << source.remaining() << " bytes of data, but its header (shape "
      << shape.str() << ", " << dtype_name(h.dtype) << ") needs " << bytes;
    throw IoError(s.str());
  }
  checked_volume_bytes(shape, h.dtype, limits.max_bytes, what);
  Volume volume(shape, h.dtype);
  const std::size_t element = dtype_size(h.dtype);
  if (!h.fortran_order) {
    constexpr std::size_t kPiece = std::size_t(64) << 20;
    for (std::size_t done = 0; done < bytes;) {
      const std::size_t n = std::min(kPiece, bytes - done);
      source.read(volume.bytes() + done, n);
      done += n;
    }
    if (h.big_endian) byte_swap_in_place(volume.bytes(), bytes / element, element);
  } else {
    // Fortran order: element (i, j, k) of shape (a, b, c) sits at i + a * (j + b * k). Stream one
    // k-plane (a * b elements) at a time and scatter it to C positions (i * b + j) * c + k.
    const auto a = static_cast<std::size_t>(shape.nz), b = static_cast<std::size_t>(shape.ny),
               c = static_cast<std::size_t>(shape.nx);
    std::vector<std::byte> plane(a * b * element);
    for (std::size_t k = 0; k < c; ++k) {
      source.read(plane.data(), plane.size());
      if (h.big_endian) byte_swap_in_place(plane.data(), a * b, element);
      for (std::size_t j = 0; j < b; ++j) {
        for (std::size_t i = 0; i < a; ++i) {
          std::memcpy(volume.bytes() + ((i * b + j) * c + k) * element,
                      plane.data() + (i + a * j) * element, element);
        }
      }
    }
  }
  source.finish();
  if (h.dtype == DType::kBool) fix_bool(volume.data<std::uint8_t>(), bytes);
  return volume;
}

}  // namespace

Volume read_npy(const fs::path& path, const ReadLimits& limits, ReadReport* report) {
  const std::uint64_t size = file_size_or_throw(path);
  auto source = file_region_source(path, 0, size, path.string());
  Volume volume = read_npy_stream(*source, path.string(), limits);
  if (report) report->format = "npy";
  return volume;
}

std::vector<std::string> list_npz_arrays(const fs::path& path) {
  ZipArchive zip(path);
  std::vector<std::string> names;
  for (const ZipMember& m : zip.members()) {
    std::string n = m.name;
    if (n.size() > 4 && n.compare(n.size() - 4, 4, ".npy") == 0) n.resize(n.size() - 4);
    names.push_back(n);
  }
  return names;
}

Volume read_npz(const fs::path& path, const std::string& array, const ReadLimits& limits,
                ReadReport* report) {
  const std::string name = path.string();
  ZipArchive zip(path);
  const ZipMember* member = nullptr;
  if (array.empty()) {
    if (zip.members().size() != 1) {
      std::string names;
      for (const std::string& n : list_npz_arrays(path)) names += (names.empty() ? "" : ", ") + n;
      throw ConfigError(name + ": holds " + std::to_string(zip.members().size()) + " arrays (" +
                        names + "); choose one with --array");
    }
    member = &zip.members().front();
  } else {
    member = zip.find(array);
    if (!member) member = zip.find(array + ".npy");
    if (!member) {
      std::string names;
      for (const std::string& n : list_npz_arrays(path)) names += (names.empty() ? "" : ", ") + n;
      throw ConfigError(name + ": no array '" + array + "' (it holds: " + names + ")");
    }
  }
  const std::string what = name + ": " + member->name;
  // Deflate expands at most ~1032:1; a member claiming more than that is corrupt, and is refused
  // before the npy header inside it could make us allocate.
  if (member->method == 8 &&
      double(member->uncompressed_size) > 1032.0 * double(member->compressed_size) + 4096.0) {
    throw IoError(what + ": claims " + std::to_string(member->uncompressed_size) + " bytes from " +
                  std::to_string(member->compressed_size) + " compressed (corrupt archive)");
  }
  auto source = zip.open(*member);
  Volume volume = read_npy_stream(*source, what, limits);
  if (report) report->format = "npz";
  return volume;
}

void write_npy(const Volume& volume, const fs::path& path, bool fortran_order) {
  const std::string name = path.string();
  const char* descr = "|u1";
  switch (volume.dtype()) {
    case DType::kBool:
      descr = "|b1";
      break;
    case DType::kInt8:
      descr = "|i1";
      break;
    case DType::kUInt8:
      descr = "|u1";
      break;
    case DType::kUInt16:
      descr = "<u2";
      break;
    case DType::kFloat32:
      descr = "<f4";
      break;
  }
  const Shape& s = volume.shape();
  std::string dict = std::string("{'descr': '") + descr +
                     "', 'fortran_order': " + (fortran_order ? "True" : "False") + ", 'shape': (" +
                     std::to_string(s.nz) + ", " + std::to_string(s.ny) + ", " +
                     std::to_string(s.nx) + "), }";
  // Pad so that the data start on a 64-byte boundary, as NumPy does; end with a newline.
  while ((10 + dict.size() + 1) % 64 != 0) dict += ' ';
  dict += '\n';
  FilePtr f = open_or_throw(path, "wb");
  unsigned char prefix[10] = {0x93,
                              'N',
                              'U',
                              'M',
                              'P',
                              'Y',
                              1,
                              0,
                              static_cast<unsigned char>(dict.size() & 0xff),
                              static_cast<unsigned char>(dict.size() >> 8)};
  write_exactly(f.get(), prefix, 10, name);
  write_exactly(f.get(), dict.data(), dict.size(), name);
  const std::size_t element = dtype_size(volume.dtype());
  if (!fortran_order) {
    write_exactly(f.get(), volume.bytes(), volume.byte_size(), name);
  } else {
    const auto a = static_cast<std::size_t>(s.nz), b = static_cast<std::size_t>(s.ny),
               c = static_cast<std::size_t>(s.nx);
    std::vector<std::byte> plane(a * b * element);
    for (std::size_t k = 0; k < c; ++k) {
      for (std::size_t j = 0; j < b; ++j) {
        for (std::size_t i = 0; i < a; ++i) {
          std::memcpy(plane.data() + (i + a * j) * element,
                      volume.bytes() + ((i * b + j) * c + k) * element, element);
        }
      }
      write_exactly(f.get(), plane.data(), plane.size(), name);
    }
  }
  if (std::fclose(f.release()) != 0) throw IoError(name + ": write failed on close");
}

}  // namespace mesorock::voxel
