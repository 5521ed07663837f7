#include "voxel/zip_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>

#include "mesorock/errors.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {
namespace {

constexpr std::uint32_t kEndOfCentralDirectory = 0x06054b50;
constexpr std::uint32_t kZip64EndLocator = 0x07064b50;
constexpr std::uint32_t kZip64End = 0x06064b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kLocalHeader = 0x04034b50;

std::uint16_t le16(const unsigned char* p) {
  return std::uint16_t(p[0] | (p[1] << 8));
}
std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
         (std::uint32_t(p[3]) << 24);
}
std::uint64_t le64(const unsigned char* p) {
  return std::uint64_t(le32(p)) | (std::uint64_t(le32(p + 4)) << 32);
}

std::vector<unsigned char> read_at(std::FILE* f, std::uint64_t offset, std::size_t n,
                                   const std::string& what) {
  std::vector<unsigned char> buffer(n);
  if (std::fseek(f, static_cast<long>(offset), SEEK_SET) != 0) {
    throw IoError(what + ": cannot seek (corrupt zip?)");
  }
  read_exactly(f, buffer.data(), n, what);
  return buffer;
}

// Stored member: bytes straight from the file, with a running CRC.
class StoredSource : public ByteSource {
 public:
  StoredSource(std::unique_ptr<ByteSource> region, const ZipMember& member, std::string what)
      : region_(std::move(region)), member_(member), what_(std::move(what)) {}
  void read(void* dst, std::size_t n) override {
    region_->read(dst, n);
    crc_ = crc32_z(crc_, static_cast<const Bytef*>(dst), n);
  }
  std::uint64_t remaining() const override { return region_->remaining(); }
  void finish() override {
    if (region_->remaining() != 0 || crc_ != member_.crc32) {
      throw IoError(what_ + ": CRC mismatch (corrupt archive)");
    }
  }

 private:
  std::unique_ptr<ByteSource> region_;
  ZipMember member_;
  std::string what_;
  uLong crc_ = crc32_z(0, nullptr, 0);
};

// Deflated member: raw inflate (no zlib header), fed 1 MiB at a time.
class InflateSource : public ByteSource {
 public:
  InflateSource(std::unique_ptr<ByteSource> region, const ZipMember& member, std::string what)
      : region_(std::move(region)), member_(member), what_(std::move(what)), input_(1 << 20) {
    if (inflateInit2(&z_, -15) != Z_OK) throw IoError(what_ + ": zlib initialisation failed");
    left_ = member.uncompressed_size;
  }
  ~InflateSource() override { inflateEnd(&z_); }
  void read(void* dst, std::size_t n) override {
    if (n > left_) throw IoError(what_ + ": member is shorter than its content claims");
    auto* out = static_cast<unsigned char*>(dst);
    std::size_t wanted = n;
    while (wanted > 0) {
      if (ended_) throw IoError(what_ + ": compressed stream ends early (corrupt archive)");
      if (z_.avail_in == 0 && region_->remaining() > 0) {
        const auto chunk =
            static_cast<std::size_t>(std::min<std::uint64_t>(input_.size(), region_->remaining()));
        region_->read(input_.data(), chunk);
        z_.next_in = input_.data();
        z_.avail_in = static_cast<uInt>(chunk);
      }
      const std::size_t piece = std::min<std::size_t>(wanted, 1u << 30);
      z_.next_out = out;
      z_.avail_out = static_cast<uInt>(piece);
      const int status = inflate(&z_, Z_NO_FLUSH);
      const std::size_t produced = piece - z_.avail_out;
      if (status == Z_STREAM_END) {
        ended_ = true;
      } else if (status != Z_OK && !(status == Z_BUF_ERROR && produced > 0)) {
        throw IoError(what_ + ": corrupt compressed data (" +
                      (z_.msg ? std::string(z_.msg) : std::string("no progress")) + ")");
      }
      crc_ = crc32_z(crc_, out, produced);
      out += produced;
      wanted -= produced;
    }
    left_ -= n;
  }
  std::uint64_t remaining() const override { return left_; }
  void finish() override {
    if (left_ != 0) throw IoError(what_ + ": member not fully read");
    if (crc_ != member_.crc32) throw IoError(what_ + ": CRC mismatch (corrupt archive)");
  }

 private:
  std::unique_ptr<ByteSource> region_;
  ZipMember member_;
  std::string what_;
  std::vector<unsigned char> input_;
  z_stream z_{};
  std::uint64_t left_ = 0;
  bool ended_ = false;
  uLong crc_ = crc32_z(0, nullptr, 0);
};

}  // namespace

ZipArchive::ZipArchive(const fs::path& path) : path_(path) {
  const std::string name = path.string();
  file_size_ = file_size_or_throw(path);
  if (file_size_ < 22) throw IoError(name + ": too short to be a zip archive");
  FilePtr f = open_or_throw(path, "rb");

  // The end-of-central-directory record sits in the last 22 + 65535 (comment) bytes.
  const std::size_t tail_size =
      static_cast<std::size_t>(std::min<std::uint64_t>(file_size_, 22 + 65535));
  const std::vector<unsigned char> tail = read_at(f.get(), file_size_ - tail_size, tail_size, name);
  std::size_t eocd = std::string::npos;
  for (std::size_t i = tail_size - 22 + 1; i-- > 0;) {
    if (le32(&tail[i]) == kEndOfCentralDirectory) {
      eocd = i;
      break;
    }
  }
  if (eocd == std::string::npos) throw IoError(name + ": not a zip archive (no central directory)");
  const unsigned char* e = &tail[eocd];
  if (le16(e + 4) != 0 || le16(e + 6) != 0) throw IoError(name + ": multi-disk zip not supported");
  std::uint64_t entries = le16(e + 10);
  std::uint64_t cd_size = le32(e + 12);
  std::uint64_t cd_offset = le32(e + 16);
  const std::uint64_t eocd_offset = file_size_ - tail_size + eocd;
  if (entries == 0xFFFF || cd_size == 0xFFFFFFFFu || cd_offset == 0xFFFFFFFFu) {
    if (eocd_offset < 20) throw IoError(name + ": corrupt zip64 archive");
    const auto locator = read_at(f.get(), eocd_offset - 20, 20, name);
    if (le32(locator.data()) != kZip64EndLocator) throw IoError(name + ": corrupt zip64 archive");
    const std::uint64_t z64 = le64(&locator[8]);
    if (z64 > file_size_ - 56) throw IoError(name + ": corrupt zip64 archive");
    const auto record = read_at(f.get(), z64, 56, name);
    if (le32(record.data()) != kZip64End) throw IoError(name + ": corrupt zip64 archive");
    entries = le64(&record[32]);
    cd_size = le64(&record[40]);
    cd_offset = le64(&record[48]);
  }
  if (cd_offset > file_size_ || cd_size > file_size_ - cd_offset || entries > cd_size / 46) {
    throw IoError(name + ": corrupt zip archive (central directory out of range)");
  }
  const auto cd = read_at(f.get(), cd_offset, static_cast<std::size_t>(cd_size), name);
  std::size_t p = 0;
  for (std::uint64_t i = 0; i < entries; ++i) {
    if (p + 46 > cd.size() || le32(&cd[p]) != kCentralHeader) {
      throw IoError(name + ": corrupt zip archive (central directory entry " + std::to_string(i) +
                    ")");
    }
    const unsigned char* h = &cd[p];
    ZipMember m;
    const std::uint16_t flags = le16(h + 8);
    m.method = le16(h + 10);
    m.crc32 = le32(h + 16);
    m.compressed_size = le32(h + 20);
    m.uncompressed_size = le32(h + 24);
    const std::size_t name_len = le16(h + 28), extra_len = le16(h + 30), comment_len = le16(h + 32);
    m.local_header_offset = le32(h + 42);
    if (p + 46 + name_len + extra_len + comment_len > cd.size()) {
      throw IoError(name + ": corrupt zip archive (central directory entry " + std::to_string(i) +
                    ")");
    }
    m.name.assign(reinterpret_cast<const char*>(h + 46), name_len);
    // Zip64 extra field: the 64-bit values present are those whose 32-bit field is 0xFFFFFFFF.
    const unsigned char* x = h + 46 + name_len;
    for (std::size_t q = 0; q + 4 <= extra_len;) {
      const std::uint16_t id = le16(x + q), len = le16(x + q + 2);
      if (q + 4 + len > extra_len) break;
      if (id == 0x0001) {
        std::size_t r = q + 4;
        auto take = [&](std::uint64_t& field) {
          if (field == 0xFFFFFFFFu && r + 8 <= q + 4 + len) {
            field = le64(x + r);
            r += 8;
          }
        };
        take(m.uncompressed_size);
        take(m.compressed_size);
        take(m.local_header_offset);
      }
      q += 4 + len;
    }
    if (flags & 1u) throw IoError(name + ": member " + m.name + " is encrypted");
    p += 46 + name_len + extra_len + comment_len;
    members_.push_back(std::move(m));
  }
}

const ZipMember* ZipArchive::find(const std::string& name) const {
  for (const ZipMember& m : members_) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

std::unique_ptr<ByteSource> ZipArchive::open(const ZipMember& member) const {
  const std::string what = path_.string() + ": " + member.name;
  if (member.method != 0 && member.method != 8) {
    throw IoError(what + ": compression method " + std::to_string(member.method) +
                  " not supported (stored or deflated only)");
  }
  FilePtr f = open_or_throw(path_, "rb");
  if (member.local_header_offset > file_size_ || file_size_ - member.local_header_offset < 30) {
    throw IoError(what + ": local header out of range (corrupt archive)");
  }
  const auto local = read_at(f.get(), member.local_header_offset, 30, what);
  if (le32(local.data()) != kLocalHeader) throw IoError(what + ": bad local header");
  // Sizes come from the central directory: NumPy's zip64 local headers hold 0xFFFFFFFF there.
  const std::uint64_t data_offset =
      member.local_header_offset + 30 + le16(&local[26]) + le16(&local[28]);
  if (member.method == 0 && member.compressed_size != member.uncompressed_size) {
    throw IoError(what + ": stored member with different sizes (corrupt archive)");
  }
  auto region = file_region_source(path_, data_offset, member.compressed_size, what);
  if (member.method == 0) return std::make_unique<StoredSource>(std::move(region), member, what);
  return std::make_unique<InflateSource>(std::move(region), member, what);
}

}  // namespace mesorock::voxel
