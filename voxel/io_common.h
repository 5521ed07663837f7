#pragma once
// Small pieces every loader and writer shares.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "voxel/volume.h"

namespace mesorock::voxel {

// What a loader found besides the voxels: the format, where the spacing came from, and anything
// the user should hear about (printed by the command line as warnings).
struct ReadReport {
  std::string format;                   // "tiff-folder", "tiff", "raw", "mhd", "npy", ...
  std::string spacing_source = "none";  // "metadata", "command line" or "none"
  std::vector<std::string> warnings;
  nlohmann::json provenance;  // a mesorock sidecar's content when the input has one, else null
  // NaN and infinite voxels of a float32 input (load_volume counts them, and warns when there
  // are any: segment labels them outside, see NonFiniteCounts).
  NonFiniteCounts non_finite;
};

// Limits shared by the loaders.
struct ReadLimits {
  std::size_t max_bytes = 0;  // 0: physical memory
};

std::uint64_t file_size_or_throw(const std::filesystem::path& path);

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;
FilePtr open_or_throw(const std::filesystem::path& path, const char* mode);

// Reads exactly `n` bytes or throws IoError naming `what` (a short read means a truncated file).
void read_exactly(std::FILE* f, void* dst, std::size_t n, const std::string& what);
void write_exactly(std::FILE* f, const void* src, std::size_t n, const std::string& what);

// A forward-only stream of bytes (a file region, or a member of a zip archive being inflated).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Reads exactly n bytes or throws IoError.
  virtual void read(void* dst, std::size_t n) = 0;
  // Bytes not yet read.
  virtual std::uint64_t remaining() const = 0;
  // Called after the last read: checks that the stream is complete and intact (CRC).
  virtual void finish() = 0;
};

// Bytes [offset, offset + length) of a file. Throws IoError if the file is shorter.
std::unique_ptr<ByteSource> file_region_source(const std::filesystem::path& path,
                                               std::uint64_t offset, std::uint64_t length,
                                               const std::string& what);

// Swaps the bytes of every element (for big-endian uint16/float32 data).
void byte_swap_in_place(void* data, std::size_t count, std::size_t element_size);

// Whitespace trimming and splitting, for the little text formats (.mhd, npy headers).
std::string trim(const std::string& s);
std::vector<std::string> split(const std::string& s, char sep);
std::string lowercase(std::string s);

// Normalises a few spellings of common length units ("micron", "\u00b5m" -> "um").
std::string normalize_unit(const std::string& unit);

}  // namespace mesorock::voxel
