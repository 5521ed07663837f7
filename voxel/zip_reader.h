#pragma once
// A minimal zip reader, enough for NumPy .npz archives.
//
// Why hand-written: .npz is a zip file, and the project's dependency list has zlib but no zip
// library. NumPy writes members either stored (np.savez) or deflated (np.savez_compressed), with
// zip64 extra fields (it forces zip64 on every member). Reading those needs only the central
// directory, the local headers, and zlib's raw inflate; encryption, multi-disk archives and other
// methods are refused with a clear message.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "voxel/io_common.h"

namespace mesorock::voxel {

struct ZipMember {
  std::string name;
  std::uint16_t method = 0;  // 0 stored, 8 deflated
  std::uint32_t crc32 = 0;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint64_t local_header_offset = 0;
};

class ZipArchive {
 public:
  // Reads the central directory. Throws IoError (naming the file) for anything that is not a
  // well-formed, supported zip archive.
  explicit ZipArchive(const std::filesystem::path& path);

  const std::vector<ZipMember>& members() const { return members_; }
  const ZipMember* find(const std::string& name) const;

  // A stream of the member's uncompressed bytes; finish() checks the CRC-32 and the size.
  std::unique_ptr<ByteSource> open(const ZipMember& member) const;

 private:
  std::filesystem::path path_;
  std::uint64_t file_size_ = 0;
  std::vector<ZipMember> members_;
};

}  // namespace mesorock::voxel
