#include "voxel/raw_io.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "voxel/staged_output.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {
namespace {

std::string bytes_text(std::uint64_t n) {
  return std::to_string(n) + " bytes";
}

// Bool volumes hold 0 or 1; foreign files may use 255 for true.
void normalize_bool(Volume& volume) {
  if (volume.dtype() != DType::kBool) return;
  std::uint8_t* v = volume.data<std::uint8_t>();
  const std::int64_t n = volume.voxels();
  for (std::int64_t i = 0; i < n; ++i) v[i] = v[i] != 0;
}

void read_into(std::FILE* f, Volume& volume, const std::string& what, bool big_endian) {
  // Read in 64 MiB pieces: a single multi-GiB fread is fine on Linux, but pieces keep error
  // messages precise and let the OS start on page faults early.
  constexpr std::size_t kPiece = std::size_t(64) << 20;
  std::byte* dst = volume.bytes();
  std::size_t left = volume.byte_size();
  while (left > 0) {
    const std::size_t n = std::min(left, kPiece);
    read_exactly(f, dst, n, what);
    dst += n;
    left -= n;
  }
  if (big_endian) {
    byte_swap_in_place(volume.bytes(), static_cast<std::size_t>(volume.voxels()),
                       dtype_size(volume.dtype()));
  }
  normalize_bool(volume);
}

// Inflates a zlib stream of `compressed` bytes from f into the volume; the result must fill the
// volume exactly.
void inflate_into(std::FILE* f, std::uint64_t compressed, Volume& volume, const std::string& what,
                  bool big_endian) {
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK) throw IoError(what + ": zlib initialisation failed");
  std::vector<unsigned char> in(1 << 20);
  std::byte* out = volume.bytes();
  std::size_t out_left = volume.byte_size();
  std::uint64_t in_left = compressed;
  int status = Z_OK;
  try {
    while (status != Z_STREAM_END) {
      if (z.avail_in == 0) {
        if (in_left == 0) throw IoError(what + ": compressed data ends early (truncated?)");
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(in.size(), in_left));
        read_exactly(f, in.data(), n, what);
        in_left -= n;
        z.next_in = in.data();
        z.avail_in = static_cast<uInt>(n);
      }
      const std::size_t chunk = std::min<std::size_t>(out_left, 1u << 30);
      z.next_out = reinterpret_cast<Bytef*>(out);
      z.avail_out = static_cast<uInt>(chunk);
      status = inflate(&z, Z_NO_FLUSH);
      const std::size_t produced = chunk - z.avail_out;
      out += produced;
      out_left -= produced;
      if (status == Z_BUF_ERROR && out_left == 0) {
        throw IoError(what + ": compressed data holds more voxels than the header says");
      }
      if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR) {
        throw IoError(what + ": corrupt compressed data (" + (z.msg ? z.msg : "zlib error") + ")");
      }
    }
    if (out_left != 0) {
      throw IoError(what + ": compressed data holds fewer voxels than the header says");
    }
  } catch (...) {
    inflateEnd(&z);
    throw;
  }
  inflateEnd(&z);
  if (big_endian) {
    byte_swap_in_place(volume.bytes(), static_cast<std::size_t>(volume.voxels()),
                       dtype_size(volume.dtype()));
  }
  normalize_bool(volume);
}

const char* met_type(DType dtype) {
  switch (dtype) {
    case DType::kBool:
    case DType::kUInt8:
      return "MET_UCHAR";
    case DType::kInt8:
      return "MET_CHAR";
    case DType::kUInt16:
      return "MET_USHORT";
    case DType::kFloat32:
      return "MET_FLOAT";
  }
  return "MET_UCHAR";
}

bool parse_bool_word(const std::string& value) {
  const std::string v = lowercase(trim(value));
  return v == "true" || v == "1" || v == "yes";
}

std::vector<double> parse_numbers(const std::string& value, const std::string& what) {
  std::vector<double> numbers;
  std::istringstream s(value);
  std::string token;
  while (s >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') throw IoError(what + ": bad number '" + token + "'");
    numbers.push_back(v);
  }
  return numbers;
}

// A mesorock sidecar is our own file, so a field of the wrong kind is a damaged file, not an
// option: refuse it here, naming the file, rather than let a later reader meet a type error.
void check_sidecar(const nlohmann::json& sidecar, const std::string& name) {
  const auto refuse = [&](const std::string& key, const char* kind) {
    throw IoError(name + ": '" + key + "' must be " + kind);
  };
  for (const char* key : {"unit", "dtype"}) {
    if (sidecar.contains(key) && !sidecar[key].is_string()) refuse(key, "a string");
  }
  if (sidecar.contains("origin_zyx")) {
    const nlohmann::json& o = sidecar["origin_zyx"];
    const auto finite = [](const nlohmann::json& v) {
      return v.is_number() && std::isfinite(v.get<double>());
    };
    if (!o.is_array() || o.size() != 3 || !std::all_of(o.begin(), o.end(), finite))
      refuse("origin_zyx", "three finite numbers (z, y, x)");
  }
}

}  // namespace

fs::path sidecar_path(const fs::path& header) {
  fs::path p = header;
  return p.replace_extension(".json");
}

Volume read_raw(const fs::path& path, const RawOptions& options, const ReadLimits& limits,
                ReadReport* report) {
  const std::string name = path.string();
  const std::uint64_t size = file_size_or_throw(path);
  const std::size_t bytes = claimed_bytes(options.shape, options.dtype, name);
  if (size != options.header_bytes + bytes) {
    std::ostringstream s;
    s << name << ": holds " << bytes_text(size) << ", but shape " << options.shape.str() << " "
      << dtype_name(options.dtype) << " needs " << bytes_text(options.header_bytes + bytes);
    if (options.header_bytes) s << " (including a " << options.header_bytes << "-byte header)";
    throw IoError(s.str());
  }
  checked_volume_bytes(options.shape, options.dtype, limits.max_bytes, name);
  Volume volume(options.shape, options.dtype, options.spacing);
  FilePtr f = open_or_throw(path, "rb");
  if (options.header_bytes && std::fseek(f.get(), long(options.header_bytes), SEEK_SET) != 0) {
    throw IoError(name + ": cannot seek past the header");
  }
  read_into(f.get(), volume, name, options.big_endian);
  if (report) {
    report->format = "raw";
    report->spacing_source = options.spacing.known() ? "command line" : "none";
  }
  return volume;
}

Volume read_mhd(const fs::path& header, const ReadLimits& limits, ReadReport* report) {
  const std::string name = header.string();
  const std::uint64_t header_file_size = file_size_or_throw(header);
  // Key = value lines up to ElementDataFile, which MetaImage requires to be the last key. Only
  // the first 64 KiB are looked at, so a binary file given by mistake is not read whole.
  std::string text(static_cast<std::size_t>(std::min<std::uint64_t>(header_file_size, 65536)),
                   '\0');
  {
    FilePtr f = open_or_throw(header, "rb");
    read_exactly(f.get(), text.data(), text.size(), name);
  }
  std::map<std::string, std::string> keys;
  std::uint64_t header_end = 0;
  bool found_data_key = false;
  int lines = 0;
  std::size_t pos = 0;
  while (pos < text.size() && !found_data_key) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    header_end = pos;
    ++lines;
    if (line.find('\0') != std::string::npos) break;  // binary data, not a header
    const auto eq = line.find('=');
    if (eq == std::string::npos) {
      if (trim(line).empty()) continue;
      throw IoError(name + ": not a MetaImage header (line " + std::to_string(lines) +
                    " has no '=')");
    }
    const std::string key = trim(line.substr(0, eq));
    keys[key] = trim(line.substr(eq + 1));
    found_data_key = key == "ElementDataFile";
  }
  if (!found_data_key) throw IoError(name + ": not a MetaImage header (no ElementDataFile)");
  auto get = [&](const std::string& key) -> std::string {
    auto it = keys.find(key);
    return it == keys.end() ? std::string() : it->second;
  };

  const std::string object_type = get("ObjectType");
  if (!object_type.empty() && object_type != "Image") {
    throw IoError(name + ": ObjectType " + object_type + " (expected Image)");
  }
  const std::string channels = get("ElementNumberOfChannels");
  if (!channels.empty() && std::atoi(channels.c_str()) != 1) {
    throw IoError(name + ": " + channels + " channels per voxel; a grey-level image needs 1");
  }
  const std::vector<double> dims = parse_numbers(get("DimSize"), name);
  const int ndims = get("NDims").empty() ? int(dims.size()) : std::atoi(get("NDims").c_str());
  if ((ndims != 2 && ndims != 3) || int(dims.size()) != ndims) {
    throw IoError(name + ": NDims " + std::to_string(ndims) + " with DimSize '" + get("DimSize") +
                  "' (expected a 2-D or 3-D image)");
  }
  for (double d : dims) {
    if (d < 1 || d > 9.0e15 || d != std::floor(d)) {
      throw IoError(name + ": bad DimSize '" + get("DimSize") + "'");
    }
  }
  // MetaImage lists x first.
  const Shape shape{ndims == 3 ? std::int64_t(dims[2]) : 1, std::int64_t(dims[1]),
                    std::int64_t(dims[0])};
  const std::string element_type = get("ElementType");
  DType dtype;
  if (element_type == "MET_UCHAR") {
    dtype = DType::kUInt8;
  } else if (element_type == "MET_CHAR") {
    dtype = DType::kInt8;
  } else if (element_type == "MET_USHORT") {
    dtype = DType::kUInt16;
  } else if (element_type == "MET_FLOAT") {
    dtype = DType::kFloat32;
  } else {
    throw IoError(name + ": ElementType '" + element_type +
                  "' is not supported (MET_UCHAR, MET_CHAR, MET_USHORT, MET_FLOAT)");
  }

  Spacing spacing;
  std::string spacing_text = get("ElementSpacing");
  if (spacing_text.empty()) spacing_text = get("ElementSize");
  if (!spacing_text.empty()) {
    const std::vector<double> s = parse_numbers(spacing_text, name);
    if (int(s.size()) != ndims)
      throw IoError(name + ": ElementSpacing needs " + std::to_string(ndims) + " values");
    spacing.dx = s[0];
    spacing.dy = s[1];
    spacing.dz = ndims == 3 ? s[2] : 1.0;
    spacing.unit = "mm";  // the ITK convention, unless our sidecar says otherwise (below)
  }

  nlohmann::json sidecar;
  const fs::path sidecar_file = sidecar_path(header);
  if (fs::exists(sidecar_file)) {
    try {
      std::ifstream s(sidecar_file);
      nlohmann::json j = nlohmann::json::parse(s);
      if (j.value("generator", "") == "mesorock") sidecar = std::move(j);
    } catch (const std::exception&) {
      // Not our sidecar (or not JSON): MetaImage itself is complete without it.
    }
  }
  if (sidecar.is_object()) {
    check_sidecar(sidecar, sidecar_file.string());
    if (sidecar.contains("unit")) spacing.unit = sidecar["unit"].get<std::string>();
    if (sidecar.value("dtype", "") == "bool" && dtype == DType::kUInt8) dtype = DType::kBool;
  } else if (!spacing_text.empty() && report) {
    report->warnings.push_back(name +
                               ": MetaImage has no length unit; assuming mm (the ITK "
                               "convention); pass --unit to override");
  }
  if (!spacing_text.empty()) validate_spacing(spacing, name + ": ElementSpacing");

  const bool big_endian =
      parse_bool_word(get("BinaryDataByteOrderMSB")) || parse_bool_word(get("ElementByteOrderMSB"));
  const bool compressed = parse_bool_word(get("CompressedData"));
  const std::string binary = get("BinaryData");
  if (!binary.empty() && !parse_bool_word(binary)) {
    throw IoError(name + ": ASCII MetaImage data (BinaryData = False) is not supported");
  }
  const std::string data_name = get("ElementDataFile");
  if (data_name == "LIST" || data_name.find('%') != std::string::npos) {
    throw IoError(name + ": ElementDataFile '" + data_name +
                  "' (a list of slice files) is not supported");
  }
  const bool local = data_name == "LOCAL";
  const fs::path data_path = local ? header : header.parent_path() / data_name;
  const std::string data_display = data_path.string();
  const std::uint64_t data_size = local ? header_file_size : file_size_or_throw(data_path);
  const std::size_t bytes = claimed_bytes(shape, dtype, name);
  const long long header_size =
      get("HeaderSize").empty() ? 0 : std::atoll(get("HeaderSize").c_str());
  const std::uint64_t base = local ? header_end : 0;

  std::uint64_t offset = 0;
  std::uint64_t stored = 0;  // bytes of (possibly compressed) data
  if (compressed) {
    offset = base + std::uint64_t(std::max(0LL, header_size));
    if (offset > data_size) throw IoError(data_display + ": shorter than its header offset");
    stored = data_size - offset;
    if (!get("CompressedDataSize").empty()) {
      const std::uint64_t claimed = std::strtoull(get("CompressedDataSize").c_str(), nullptr, 10);
      if (claimed > stored) {
        throw IoError(data_display + ": holds " + bytes_text(stored) + " of compressed data, but " +
                      name + " says CompressedDataSize = " + std::to_string(claimed));
      }
      stored = claimed;
    }
    if (double(bytes) > 1032.0 * double(stored) + 4096.0) {  // deflate's maximum ratio
      throw IoError(name + ": DimSize " + get("DimSize") + " " + element_type + " needs " +
                    bytes_text(bytes) + ", more than " + data_display + " (" + bytes_text(stored) +
                    " compressed) can hold");
    }
  } else {
    if (header_size < 0) {
      if (data_size < base + bytes) {
        throw IoError(data_display + ": holds " + bytes_text(data_size - base) + ", but " + name +
                      " (DimSize " + get("DimSize") + ", " + element_type + ") needs " +
                      bytes_text(bytes));
      }
      offset = data_size - bytes;  // HeaderSize = -1: the data are the file's last bytes
    } else {
      offset = base + std::uint64_t(header_size);
      if (data_size != offset + bytes) {
        throw IoError(data_display + ": holds " +
                      bytes_text(data_size - std::min(data_size, base)) + ", but " + name +
                      " (DimSize " + get("DimSize") + ", " + element_type +
                      (header_size ? ", HeaderSize " + std::to_string(header_size) : "") +
                      ") needs " + bytes_text(offset - base + bytes));
      }
    }
  }

  checked_volume_bytes(shape, dtype, limits.max_bytes, name);
  Volume volume(shape, dtype, spacing);
  FilePtr f = open_or_throw(data_path, "rb");
  if (offset && std::fseek(f.get(), long(offset), SEEK_SET) != 0) {
    throw IoError(data_display + ": cannot seek to the data");
  }
  if (compressed) {
    inflate_into(f.get(), stored, volume, data_display, big_endian);
  } else {
    read_into(f.get(), volume, data_display, big_endian);
  }
  if (report) {
    report->format = "mhd";
    report->spacing_source = spacing_text.empty() ? "none" : "metadata";
    report->provenance = sidecar;
  }
  return volume;
}

void write_raw(const Volume& volume, const fs::path& path, const std::string& display_name) {
  FilePtr f = open_or_throw(path, "wb");
  constexpr std::size_t kPiece = std::size_t(64) << 20;
  const std::byte* src = volume.bytes();
  std::size_t left = volume.byte_size();
  while (left > 0) {
    const std::size_t n = std::min(left, kPiece);
    write_exactly(f.get(), src, n, display_name);
    src += n;
    left -= n;
  }
  if (std::fclose(f.release()) != 0) throw IoError(display_name + ": write failed on close");
}

void write_mhd(const Volume& volume, StagedOutputs& outputs, const fs::path& header_target,
               const nlohmann::json& provenance) {
  fs::path raw_target = header_target;
  raw_target.replace_extension(".raw");
  const fs::path json_target = sidecar_path(header_target);
  const Shape& shape = volume.shape();
  const Spacing& spacing = volume.spacing();

  std::ostringstream header;
  header.precision(17);
  header << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
         << "CompressedData = False\n"
         << "TransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = 0 0 0\n"
         << "ElementSpacing = " << spacing.dx << " " << spacing.dy << " " << spacing.dz << "\n"
         << "DimSize = " << shape.nx << " " << shape.ny << " " << shape.nz << "\n"
         << "ElementType = " << met_type(volume.dtype()) << "\n"
         << "ElementDataFile = " << raw_target.filename().string() << "\n";

  nlohmann::json sidecar = provenance.is_object() ? provenance : nlohmann::json::object();
  sidecar["generator"] = "mesorock";
  sidecar["mesorock_version"] = kVersion;
  sidecar["git_commit"] = kGitCommit;
  sidecar["dtype"] = dtype_name(volume.dtype());
  sidecar["shape_zyx"] = {shape.nz, shape.ny, shape.nx};
  sidecar["spacing_zyx"] = {spacing.dz, spacing.dy, spacing.dx};
  sidecar["unit"] = spacing.unit;

  const fs::path raw_tmp = outputs.stage(raw_target);
  write_raw(volume, raw_tmp, outputs.final_path(raw_target).string());
  const fs::path json_tmp = outputs.stage(json_target);
  {
    std::ofstream out(json_tmp, std::ios::binary);
    out << sidecar.dump(2) << "\n";
    if (!out) throw IoError(outputs.final_path(json_target).string() + ": write failed");
  }
  const fs::path header_tmp = outputs.stage(header_target);
  std::ofstream out(header_tmp, std::ios::binary);
  out << header.str();
  out.close();
  if (!out) throw IoError(outputs.final_path(header_target).string() + ": write failed");
}

}  // namespace mesorock::voxel
