#include "voxel/load.h"

#include <cstring>
#include <sstream>

#include "mesorock/errors.h"
#include "voxel/hdf5_io.h"
#include "voxel/npy_io.h"
#include "voxel/raw_io.h"
#include "voxel/tiff_io.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {

const char* format_name(Format format) {
  switch (format) {
    case Format::kTiffFolder:
      return "TIFF folder";
    case Format::kTiff:
      return "TIFF";
    case Format::kNpy:
      return "NumPy .npy";
    case Format::kNpz:
      return "NumPy .npz";
    case Format::kHdf5:
      return "HDF5";
    case Format::kMetaImage:
      return "MetaImage";
    case Format::kRaw:
      return "raw";
  }
  return "?";
}

Format detect_format(const fs::path& input, const LoadOptions& options) {
  const std::string name = input.string();
  std::error_code ec;
  if (!fs::exists(input, ec)) throw IoError(name + ": no such file or folder");
  const bool raw_options = options.shape || options.dtype;
  if (fs::is_directory(input, ec)) {
    if (raw_options) throw ConfigError(name + ": --shape/--dtype are for headerless raw files");
    return Format::kTiffFolder;
  }
  const std::string ext = lowercase(input.extension().string());
  unsigned char magic[8] = {0};
  const std::uint64_t size = file_size_or_throw(input);
  {
    FilePtr f = open_or_throw(input, "rb");
    const std::size_t n = std::fread(magic, 1, sizeof magic, f.get());
    (void)n;
  }
  Format format = Format::kRaw;
  bool recognised = true;
  if (size >= 4 && ((magic[0] == 'I' && magic[1] == 'I' && (magic[2] == 42 || magic[2] == 43) &&
                     magic[3] == 0) ||
                    (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 &&
                     (magic[3] == 42 || magic[3] == 43)))) {
    format = Format::kTiff;
  } else if (size >= 6 && std::memcmp(magic, "\x93NUMPY", 6) == 0) {
    format = Format::kNpy;
  } else if (size >= 4 && magic[0] == 'P' && magic[1] == 'K' &&
             ((magic[2] == 3 && magic[3] == 4) || (magic[2] == 5 && magic[3] == 6))) {
    format = Format::kNpz;
  } else if ((size >= 8 && std::memcmp(magic, "\x89HDF\r\n\x1a\n", 8) == 0) || ext == ".h5" ||
             ext == ".hdf5" || ext == ".hdf") {  // the extension covers files with a user block
    format = Format::kHdf5;
  } else if (ext == ".mhd" || ext == ".mha") {
    format = Format::kMetaImage;
  } else {
    recognised = false;
  }
  if (recognised) {
    if (raw_options) {
      throw ConfigError(name + ": is a " + format_name(format) +
                        " file; --shape/--dtype are for headerless raw files");
    }
    return format;
  }
  if (raw_options) {
    if (!(options.shape && options.dtype)) {
      throw ConfigError(name + ": headerless raw input needs both --shape and --dtype");
    }
    return Format::kRaw;
  }

  std::ostringstream s;
  s << name << ": ";
  if (ext == ".raw" || ext == ".bin" || ext == ".dat" || ext == ".vol") {
    s << "headerless raw data need --shape Z,Y,X and --dtype";
    throw ConfigError(s.str());
  }
  if (ext == ".tif" || ext == ".tiff") {
    s << "not a TIFF file (no TIFF signature";
  } else if (ext == ".npy" || ext == ".npz") {
    s << "not a NumPy file (no npy/zip signature";
  } else {
    s << "not a recognised image format (TIFF, .npy, .npz, HDF5, .mhd; raw data need --shape "
         "and --dtype";
  }
  s << "; first bytes";
  for (std::size_t i = 0; i < std::min<std::uint64_t>(size, 4); ++i) {
    char hex[4];
    std::snprintf(hex, sizeof hex, " %02x", magic[i]);
    s << hex;
  }
  s << ")";
  throw IoError(s.str());
}

Volume load_volume(const fs::path& input, const LoadOptions& options, ReadReport* report) {
  ReadReport local;
  ReadReport& r = report ? *report : local;
  const Format format = detect_format(input, options);
  if (format != Format::kRaw && options.header_bytes) {
    throw ConfigError(input.string() + ": --header-bytes is only for headerless raw input");
  }
  if (!options.array.empty() && format != Format::kNpz) {
    throw ConfigError(input.string() + ": --array is only for .npz input");
  }
  if (!options.dataset.empty() && format != Format::kHdf5) {
    throw ConfigError(input.string() + ": --dataset is only for HDF5 input");
  }
  Volume volume;
  switch (format) {
    case Format::kTiffFolder:
      volume = read_tiff_folder(input, options.limits, &r);
      break;
    case Format::kTiff:
      volume = read_tiff_file(input, options.limits, &r);
      break;
    case Format::kNpy:
      volume = read_npy(input, options.limits, &r);
      break;
    case Format::kNpz:
      volume = read_npz(input, options.array, options.limits, &r);
      break;
    case Format::kHdf5:
      volume = read_hdf5(input, options.dataset, options.limits, &r);
      break;
    case Format::kMetaImage:
      volume = read_mhd(input, options.limits, &r);
      break;
    case Format::kRaw: {
      RawOptions raw;
      raw.shape = *options.shape;
      raw.dtype = *options.dtype;
      raw.big_endian = options.big_endian;
      raw.header_bytes = options.header_bytes;
      volume = read_raw(input, raw, options.limits, &r);
      r.spacing_source = "none";
      break;
    }
  }
  if (options.spacing) {
    validate_spacing(*options.spacing, "--spacing");
    if (r.spacing_source == "metadata" && (volume.spacing().str() != options.spacing->str())) {
      r.warnings.push_back(input.string() + ": --spacing " + options.spacing->str() +
                           " overrides the file's " + volume.spacing().str());
    }
    volume.set_spacing(*options.spacing);
    r.spacing_source = "command line";
  } else if (options.unit) {
    Spacing s = volume.spacing();
    s.unit = *options.unit;
    validate_spacing(s, input.string());
    volume.set_spacing(s);
  }
  // NaN voxels used to pass silently, and segment made them "outside" without a word.
  r.non_finite = count_non_finite(volume);
  if (r.non_finite.total() > 0)
    r.warnings.push_back(input.string() + ": " + non_finite_note(r.non_finite, volume.voxels()));
  return volume;
}

}  // namespace mesorock::voxel
