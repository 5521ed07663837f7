#include "voxel/tiff_io.h"

#include <tbb/parallel_for.h>
#include <tiffio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdarg>
#include <cstring>
#include <mutex>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "voxel/staged_output.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {
namespace {

// libtiff reports problems through global handlers that print to stderr by default. We route
// them into a per-thread buffer instead (slices are decoded on several threads) and turn the
// first error of an operation into the IoError message.
thread_local std::string t_tiff_error;

void capture_tiff_error(const char* /*module*/, const char* fmt, va_list ap) {
  if (!t_tiff_error.empty()) return;  // the first error is the cause; later ones are fallout
  char buffer[512];
  std::vsnprintf(buffer, sizeof buffer, fmt, ap);
  t_tiff_error = buffer;
  std::replace(t_tiff_error.begin(), t_tiff_error.end(), '\n', ' ');
}

void ignore_tiff_warning(const char*, const char*, va_list) {}

void install_tiff_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    TIFFSetErrorHandler(capture_tiff_error);
    TIFFSetWarningHandler(ignore_tiff_warning);
  });
  t_tiff_error.clear();
}

std::string take_tiff_error() {
  std::string e = t_tiff_error.empty() ? "libtiff gave no detail" : t_tiff_error;
  t_tiff_error.clear();
  return e;
}

struct TiffCloser {
  void operator()(TIFF* t) const {
    if (t) TIFFClose(t);
  }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

TiffPtr open_tiff(const fs::path& path, const char* mode, const std::string& name) {
  install_tiff_handlers();
  TiffPtr tif(TIFFOpen(path.c_str(), mode));
  if (!tif) throw IoError(name + ": not a readable TIFF (" + take_tiff_error() + ")");
  return tif;
}

struct PageInfo {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint16_t bits = 8;
  DType dtype = DType::kUInt8;
  bool tiled = false;
  std::string description;
  float x_resolution = 0;
  float y_resolution = 0;

  std::string kind() const {
    return std::to_string(width) + "x" + std::to_string(height) + " " + dtype_name(dtype);
  }
  bool same_layout(const PageInfo& o) const {
    return width == o.width && height == o.height && dtype == o.dtype;
  }
};

const char* sample_format_name(std::uint16_t format) {
  switch (format) {
    case SAMPLEFORMAT_INT:
      return "signed integer";
    case SAMPLEFORMAT_IEEEFP:
      return "float";
    case SAMPLEFORMAT_COMPLEXINT:
    case SAMPLEFORMAT_COMPLEXIEEEFP:
      return "complex";
    default:
      return "unsigned integer";
  }
}

// The largest expansion a codec can achieve, used to reject a header whose pixel count the file
// cannot possibly hold before anything is allocated. 0: unknown codec, no bound.
double max_expansion(std::uint16_t compression) {
  switch (compression) {
    case COMPRESSION_NONE:
      return 1.0;
    case COMPRESSION_PACKBITS:
      return 64.0;  // a 2-byte run codes at most 128 bytes
    case COMPRESSION_LZW:
      return 4096.0;  // a code of >= 9 bits emits at most 4096 bytes
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE:
      return 1032.0;  // deflate's maximum ratio
    default:
      return 0.0;
  }
}

PageInfo read_page_info(TIFF* tif, const std::string& where, std::uint64_t file_size) {
  PageInfo info;
  std::uint16_t samples = 1, format = SAMPLEFORMAT_UINT, compression = COMPRESSION_NONE;
  std::uint16_t photometric = PHOTOMETRIC_MINISBLACK;
  std::uint32_t depth = 1;
  if (!TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &info.width) ||
      !TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &info.height)) {
    throw IoError(where + ": no image size in the TIFF directory");
  }
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &info.bits);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &compression);
  TIFFGetFieldDefaulted(tif, TIFFTAG_IMAGEDEPTH, &depth);
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
  if (info.width == 0 || info.height == 0) throw IoError(where + ": empty image (0 pixels)");
  if (samples != 1) {
    throw IoError(where + ": " + std::to_string(samples) +
                  " samples per pixel (colour?); a grey-level stack needs one");
  }
  if (depth != 1) throw IoError(where + ": volumetric (ImageDepth) TIFF is not supported");
  if (photometric != PHOTOMETRIC_MINISBLACK && photometric != PHOTOMETRIC_MINISWHITE) {
    throw IoError(where + ": photometric interpretation " + std::to_string(photometric) +
                  " (palette or colour); a grey-level stack is expected");
  }
  if (info.bits == 1) {
    info.dtype = DType::kBool;
  } else if (info.bits == 8 && format == SAMPLEFORMAT_INT) {
    info.dtype = DType::kInt8;
  } else if (info.bits == 8 && (format == SAMPLEFORMAT_UINT || format == SAMPLEFORMAT_VOID)) {
    info.dtype = DType::kUInt8;
  } else if (info.bits == 16 && (format == SAMPLEFORMAT_UINT || format == SAMPLEFORMAT_VOID)) {
    info.dtype = DType::kUInt16;
  } else if (info.bits == 32 && format == SAMPLEFORMAT_IEEEFP) {
    info.dtype = DType::kFloat32;
  } else {
    throw IoError(where + ": unsupported pixel type " + std::to_string(info.bits) + "-bit " +
                  sample_format_name(format) +
                  " (supported: 1-bit, 8-bit, 16-bit unsigned, 32-bit float)");
  }

  // Structure checks: every strip or tile lies inside the file, and the stored bytes can expand
  // to the claimed pixel count. Both run before any voxel memory is allocated.
  info.tiled = TIFFIsTiled(tif) != 0;
  const std::uint32_t chunks = info.tiled ? TIFFNumberOfTiles(tif) : TIFFNumberOfStrips(tif);
  if (chunks == 0) throw IoError(where + ": no strips or tiles");
  std::uint64_t stored = 0;
  for (std::uint32_t i = 0; i < chunks; ++i) {
    int err = 0;
    const std::uint64_t offset = TIFFGetStrileOffsetWithErr(tif, i, &err);
    const std::uint64_t count = TIFFGetStrileByteCountWithErr(tif, i, &err);
    if (err) throw IoError(where + ": unreadable strip table (" + take_tiff_error() + ")");
    if (offset > file_size || count > file_size - offset) {
      std::ostringstream s;
      s << where << ": pixel data runs past the end of the file (strip " << i << " ends at byte "
        << offset + count << ", file has " << file_size << " bytes; truncated?)";
      throw IoError(s.str());
    }
    stored += count;
  }
  const std::uint64_t row_bytes = (std::uint64_t(info.width) * info.bits + 7) / 8;
  const std::uint64_t needed = row_bytes * info.height;
  const double ratio = max_expansion(compression);
  const double slack = compression == COMPRESSION_NONE ? 0.0 : 4096.0;
  if (ratio > 0 && double(needed) > double(stored) * ratio + slack) {
    std::ostringstream s;
    s << where << ": header claims " << info.width << "x" << info.height << " pixels (" << needed
      << " bytes) but the file holds only " << stored << " bytes of pixel data";
    throw IoError(s.str());
  }

  char* description = nullptr;
  if (TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &description) && description) {
    info.description = description;
  }
  TIFFGetField(tif, TIFFTAG_XRESOLUTION, &info.x_resolution);
  TIFFGetField(tif, TIFFTAG_YRESOLUTION, &info.y_resolution);
  return info;
}

// Spacing from an ImageJ description ("ImageJ=...\nunit=nm\nspacing=5\n") and the resolution
// tags (pixels per unit). Returns false when the page carries no calibration.
bool spacing_from_imagej(const PageInfo& info, Spacing* spacing, ReadReport* report,
                         const std::string& where) {
  if (info.description.rfind("ImageJ=", 0) != 0) return false;
  std::string unit;
  double z_spacing = 0;
  for (const std::string& line : split(info.description, '\n')) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = trim(line.substr(0, eq));
    const std::string value = trim(line.substr(eq + 1));
    if (key == "unit") unit = normalize_unit(value);
    if (key == "spacing") z_spacing = std::strtod(value.c_str(), nullptr);
  }
  if (unit.empty() || unit == "pixel" || info.x_resolution <= 0 || info.y_resolution <= 0) {
    return false;
  }
  spacing->unit = unit;
  spacing->dx = 1.0 / info.x_resolution;
  spacing->dy = 1.0 / info.y_resolution;
  if (z_spacing > 0) {
    spacing->dz = z_spacing;
  } else {
    spacing->dz = spacing->dx;
    if (report) {
      report->warnings.push_back(where +
                                 ": metadata gives no z spacing; assuming dz = dx (pass --spacing "
                                 "to set it)");
    }
  }
  return true;
}

void unpack_bits(const unsigned char* packed, std::uint8_t* out, std::uint32_t count) {
  for (std::uint32_t x = 0; x < count; ++x) out[x] = (packed[x >> 3] >> (7 - (x & 7))) & 1u;
}

// Decodes the current directory into dst (width * height elements of the page's dtype).
void decode_page(TIFF* tif, const PageInfo& info, std::byte* dst, const std::string& where) {
  const std::size_t element = dtype_size(info.dtype);
  const std::size_t out_row = std::size_t(info.width) * element;
  const bool packed = info.bits == 1;
  if (!info.tiled) {
    std::uint32_t rows_per_strip = info.height;
    TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
    rows_per_strip = std::min(std::max<std::uint32_t>(rows_per_strip, 1), info.height);
    const tmsize_t line = TIFFScanlineSize(tif);
    std::vector<unsigned char> scratch(packed ? std::size_t(line) * rows_per_strip : 0);
    const std::uint32_t strips = TIFFNumberOfStrips(tif);
    for (std::uint32_t s = 0; s < strips; ++s) {
      const std::uint32_t row0 = s * rows_per_strip;
      if (row0 >= info.height) break;
      const std::uint32_t rows = std::min(rows_per_strip, info.height - row0);
      const tmsize_t size = tmsize_t(rows) * line;
      void* target = packed ? static_cast<void*>(scratch.data())
                            : static_cast<void*>(dst + std::size_t(row0) * out_row);
      const tmsize_t got = TIFFReadEncodedStrip(tif, s, target, size);
      if (got != size) {
        throw IoError(where + ": cannot decode strip " + std::to_string(s) + " (" +
                      (got < 0 ? take_tiff_error() : "short strip") + ")");
      }
      if (packed) {
        for (std::uint32_t r = 0; r < rows; ++r) {
          unpack_bits(scratch.data() + std::size_t(r) * line,
                      reinterpret_cast<std::uint8_t*>(dst) + std::size_t(row0 + r) * out_row,
                      info.width);
        }
      }
    }
    return;
  }
  std::uint32_t tile_w = 0, tile_h = 0;
  TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tile_w);
  TIFFGetField(tif, TIFFTAG_TILELENGTH, &tile_h);
  if (tile_w == 0 || tile_h == 0) throw IoError(where + ": tiled TIFF without tile size");
  const tmsize_t tile_bytes = TIFFTileSize(tif);
  const tmsize_t tile_row = TIFFTileRowSize(tif);
  std::vector<unsigned char> tile(static_cast<std::size_t>(tile_bytes));
  for (std::uint32_t y0 = 0; y0 < info.height; y0 += tile_h) {
    for (std::uint32_t x0 = 0; x0 < info.width; x0 += tile_w) {
      const ttile_t index = TIFFComputeTile(tif, x0, y0, 0, 0);
      const tmsize_t got = TIFFReadEncodedTile(tif, index, tile.data(), tile_bytes);
      if (got != tile_bytes) {
        throw IoError(where + ": cannot decode tile " + std::to_string(index) + " (" +
                      (got < 0 ? take_tiff_error() : "short tile") + ")");
      }
      const std::uint32_t rows = std::min(tile_h, info.height - y0);
      const std::uint32_t cols = std::min(tile_w, info.width - x0);
      for (std::uint32_t r = 0; r < rows; ++r) {
        const unsigned char* src = tile.data() + std::size_t(r) * tile_row;
        std::byte* out = dst + std::size_t(y0 + r) * out_row + std::size_t(x0) * element;
        if (packed) {
          unpack_bits(src, reinterpret_cast<std::uint8_t*>(out), cols);
        } else {
          std::memcpy(out, src, std::size_t(cols) * element);
        }
      }
    }
  }
}

std::string join_name(const fs::path& dir, const fs::path& file) {
  return (dir / file.filename()).string();
}

}  // namespace

bool natural_less(const std::string& a, const std::string& b) {
  auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      std::size_t i_end = i, j_end = j;
      while (i_end < a.size() && digit(a[i_end])) ++i_end;
      while (j_end < b.size() && digit(b[j_end])) ++j_end;
      std::size_t i_sig = i, j_sig = j;  // skip leading zeros: "007" == "7" numerically
      while (i_sig + 1 < i_end && a[i_sig] == '0') ++i_sig;
      while (j_sig + 1 < j_end && b[j_sig] == '0') ++j_sig;
      const std::size_t a_len = i_end - i_sig, b_len = j_end - j_sig;
      if (a_len != b_len) return a_len < b_len;
      const int c = a.compare(i_sig, a_len, b, j_sig, b_len);
      if (c != 0) return c < 0;
      i = i_end;
      j = j_end;
    } else {
      if (a[i] != b[j]) {
        return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      }
      ++i;
      ++j;
    }
  }
  if ((i < a.size()) != (j < b.size())) return j < b.size();
  return a < b;  // equal numerically ("7" vs "07"): any fixed order
}

std::vector<fs::path> list_tiff_slices(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw IoError(dir.string() + ": not a folder");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    const std::string ext = lowercase(entry.path().extension().string());
    if ((ext == ".tif" || ext == ".tiff") && entry.is_regular_file(ec)) {
      files.push_back(entry.path());
    }
  }
  if (ec) throw IoError(dir.string() + ": cannot list folder: " + ec.message());
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return natural_less(a.filename().string(), b.filename().string());
  });
  return files;
}

Volume read_tiff_folder(const fs::path& dir, const ReadLimits& limits, ReadReport* report) {
  const std::vector<fs::path> files = list_tiff_slices(dir);
  if (files.empty()) throw IoError(dir.string() + ": no .tif or .tiff slices in this folder");

  // Pass 1, headers only and in order, so the first inconsistent slice is the one reported.
  std::vector<PageInfo> pages;
  pages.reserve(files.size());
  for (const fs::path& file : files) {
    const std::string where = join_name(dir, file);
    const std::uint64_t size = file_size_or_throw(file);
    TiffPtr tif = open_tiff(file, "r", where);
    const tdir_t count = TIFFNumberOfDirectories(tif.get());
    if (count != 1) {
      throw IoError(where + ": has " + std::to_string(count) +
                    " pages; a slice folder needs single-page files");
    }
    pages.push_back(read_page_info(tif.get(), where, size));
    if (!pages.back().same_layout(pages.front())) {
      throw IoError(where + ": " + pages.back().kind() + " (width x height), but " +
                    files.front().filename().string() + " is " + pages.front().kind());
    }
  }

  const PageInfo& first = pages.front();
  Spacing spacing;
  const bool calibrated =
      spacing_from_imagej(first, &spacing, report, join_name(dir, files.front()));
  const Shape shape{static_cast<std::int64_t>(files.size()), first.height, first.width};
  checked_volume_bytes(shape, first.dtype, limits.max_bytes, dir.string());
  Volume volume(shape, first.dtype, spacing);

  // Pass 2: decode in parallel (compressed slices are CPU-bound). Errors are collected per slice
  // and the lowest slice's is thrown, so the message does not depend on thread timing.
  const std::size_t slice_bytes =
      static_cast<std::size_t>(shape.slice_voxels()) * dtype_size(first.dtype);
  std::vector<std::string> errors(files.size());
  tbb::parallel_for(std::size_t(0), files.size(), [&](std::size_t z) {
    const std::string where = join_name(dir, files[z]);
    try {
      TiffPtr tif = open_tiff(files[z], "r", where);
      decode_page(tif.get(), pages[z], volume.bytes() + z * slice_bytes, where);
    } catch (const std::exception& e) {
      errors[z] = e.what();
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw IoError(e);
  }
  if (report) {
    report->format = "tiff-folder";
    report->spacing_source = calibrated ? "metadata" : "none";
  }
  return volume;
}

Volume read_tiff_file(const fs::path& file, const ReadLimits& limits, ReadReport* report) {
  const std::string name = file.string();
  const std::uint64_t size = file_size_or_throw(file);
  TiffPtr tif = open_tiff(file, "r", name);
  std::vector<PageInfo> pages;
  do {
    const std::string where = name + ": page " + std::to_string(pages.size());
    pages.push_back(read_page_info(tif.get(), where, size));
    if (!pages.back().same_layout(pages.front())) {
      throw IoError(where + " is " + pages.back().kind() + " (width x height), but page 0 is " +
                    pages.front().kind());
    }
  } while (TIFFReadDirectory(tif.get()));
  if (!t_tiff_error.empty()) {
    throw IoError(name + ": after page " + std::to_string(pages.size() - 1) + ": " +
                  take_tiff_error());
  }
  const PageInfo& first = pages.front();
  Spacing spacing;
  const bool calibrated = spacing_from_imagej(first, &spacing, report, name);
  const Shape shape{static_cast<std::int64_t>(pages.size()), first.height, first.width};
  checked_volume_bytes(shape, first.dtype, limits.max_bytes, name);
  Volume volume(shape, first.dtype, spacing);
  const std::size_t slice_bytes =
      static_cast<std::size_t>(shape.slice_voxels()) * dtype_size(first.dtype);
  if (!TIFFSetDirectory(tif.get(), 0)) throw IoError(name + ": " + take_tiff_error());
  for (std::size_t z = 0; z < pages.size(); ++z) {
    if (z > 0 && !TIFFReadDirectory(tif.get())) {
      throw IoError(name + ": page " + std::to_string(z) + ": " + take_tiff_error());
    }
    decode_page(tif.get(), pages[z], volume.bytes() + z * slice_bytes,
                name + ": page " + std::to_string(z));
  }
  if (report) {
    report->format = "tiff";
    report->spacing_source = calibrated ? "metadata" : "none";
  }
  return volume;
}

namespace {

std::string imagej_description(const Volume& volume, std::size_t pages) {
  std::ostringstream s;
  s << "ImageJ=1.11a\n";
  if (pages > 1) s << "images=" << pages << "\nslices=" << pages << "\n";
  if (volume.spacing().known()) {
    s << "unit=" << volume.spacing().unit << "\nspacing=" << volume.spacing().dz << "\n";
  }
  if (pages > 1) s << "loop=false\n";
  return s.str();
}

void write_page(TIFF* tif, const Volume& volume, std::int64_t z, std::size_t pages, bool multipage,
                const TiffWriteOptions& options, const std::string& where) {
  const Shape& shape = volume.shape();
  const DType dtype = volume.dtype();
  const std::uint16_t bits = dtype == DType::kBool ? 1 : std::uint16_t(8 * dtype_size(dtype));
  const std::uint16_t format = dtype == DType::kFloat32 ? SAMPLEFORMAT_IEEEFP
                               : dtype == DType::kInt8  ? SAMPLEFORMAT_INT
                                                        : SAMPLEFORMAT_UINT;
  const auto width = static_cast<std::uint32_t>(shape.nx);
  const auto height = static_cast<std::uint32_t>(shape.ny);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, width);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, height);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, bits);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, std::uint16_t(1));
  TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, format);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  if (options.deflate) {
    TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
    if (dtype != DType::kBool && dtype != DType::kFloat32) {
      TIFFSetField(tif, TIFFTAG_PREDICTOR, PREDICTOR_HORIZONTAL);
    }
  } else {
    TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  }
  const std::size_t packed_row = (std::size_t(width) * bits + 7) / 8;
  const auto rows_per_strip =
      static_cast<std::uint32_t>(std::max<std::size_t>(1, (64 * 1024) / packed_row));
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, std::min(rows_per_strip, height));
  if (z == 0 || !multipage) {
    const std::string description = imagej_description(volume, pages);
    TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, description.c_str());
    const std::string software = std::string("mesorock ") + kVersion;
    TIFFSetField(tif, TIFFTAG_SOFTWARE, software.c_str());
  }
  if (volume.spacing().known()) {
    TIFFSetField(tif, TIFFTAG_XRESOLUTION, float(1.0 / volume.spacing().dx));
    TIFFSetField(tif, TIFFTAG_YRESOLUTION, float(1.0 / volume.spacing().dy));
    TIFFSetField(tif, TIFFTAG_RESOLUTIONUNIT, RESUNIT_NONE);
  }
  if (multipage) {
    TIFFSetField(tif, TIFFTAG_SUBFILETYPE, FILETYPE_PAGE);
    TIFFSetField(tif, TIFFTAG_PAGENUMBER, std::uint16_t(std::min<std::int64_t>(z, 65535)),
                 std::uint16_t(std::min<std::size_t>(pages, 65535)));
  }

  const std::size_t element = dtype_size(dtype);
  const std::byte* slice =
      volume.bytes() + std::size_t(z) * std::size_t(shape.slice_voxels()) * element;
  std::vector<unsigned char> strip;
  const std::uint32_t rows_used = std::min(rows_per_strip, height);
  for (std::uint32_t row0 = 0, s = 0; row0 < height; row0 += rows_used, ++s) {
    const std::uint32_t rows = std::min(rows_used, height - row0);
    // libtiff may modify the buffer (byte swapping, predictor), so always hand it a copy.
    strip.assign(packed_row * rows, 0);
    for (std::uint32_t r = 0; r < rows; ++r) {
      const std::byte* src = slice + std::size_t(row0 + r) * width * element;
      unsigned char* out = strip.data() + std::size_t(r) * packed_row;
      if (bits == 1) {
        for (std::uint32_t x = 0; x < width; ++x) {
          if (std::to_integer<unsigned>(src[x]) != 0) out[x >> 3] |= 0x80u >> (x & 7);
        }
      } else {
        std::memcpy(out, src, packed_row);
      }
    }
    if (TIFFWriteEncodedStrip(tif, s, strip.data(), tmsize_t(strip.size())) < 0) {
      throw IoError(where + ": cannot write: " + take_tiff_error());
    }
  }
  if (!TIFFWriteDirectory(tif)) throw IoError(where + ": cannot write: " + take_tiff_error());
}

}  // namespace

void write_tiff_file(const Volume& volume, const fs::path& path, const TiffWriteOptions& options,
                     const std::string& display_name) {
  const std::string where = display_name.empty() ? path.string() : display_name;
  // Classic TIFF addresses 4 GiB; leave room for directories before switching to BigTIFF.
  const bool big = volume.byte_size() > (std::size_t(1) << 32) - (std::size_t(1) << 28);
  TiffPtr tif = open_tiff(path, big ? "w8" : "w", where);
  const auto pages = static_cast<std::size_t>(volume.shape().nz);
  for (std::int64_t z = 0; z < volume.shape().nz; ++z) {
    write_page(tif.get(), volume, z, pages, pages > 1, options, where);
  }
  TIFF* raw = tif.release();
  TIFFClose(raw);  // flushes; libtiff reports failures through the error handler
  if (!t_tiff_error.empty()) throw IoError(where + ": cannot write: " + take_tiff_error());
}

std::size_t write_tiff_slices(const Volume& volume, StagedOutputs& outputs, const fs::path& subdir,
                              const TiffWriteOptions& options) {
  const std::int64_t nz = volume.shape().nz;
  const int digits = std::max<int>(4, static_cast<int>(std::to_string(nz - 1).size()));
  std::vector<fs::path> targets, temporaries;
  for (std::int64_t z = 0; z < nz; ++z) {
    std::string number = std::to_string(z);
    number.insert(
        0, static_cast<std::size_t>(digits) - std::min<std::size_t>(digits, number.size()), '0');
    targets.push_back(subdir / (options.slice_prefix + number + ".tif"));
    temporaries.push_back(outputs.stage(targets.back()));
  }
  std::vector<std::string> errors(static_cast<std::size_t>(nz));
  tbb::parallel_for(std::int64_t(0), nz, [&](std::int64_t z) {
    const std::string where = outputs.final_path(targets[z]).string();
    try {
      TiffPtr tif = open_tiff(temporaries[z], "w", where);
      write_page(tif.get(), volume, z, 1, false, options, where);
      TIFFClose(tif.release());
      if (!t_tiff_error.empty()) throw IoError(where + ": cannot write: " + take_tiff_error());
    } catch (const std::exception& e) {
      errors[z] = e.what();
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw IoError(e);
  }
  return static_cast<std::size_t>(nz);
}

}  // namespace mesorock::voxel
