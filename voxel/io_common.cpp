#include "voxel/io_common.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "mesorock/errors.h"

namespace fs = std::filesystem;

namespace mesorock::voxel {

std::uint64_t file_size_or_throw(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw IoError(path.string() + ": no such file");
  if (fs::is_directory(path, ec)) throw IoError(path.string() + ": is a folder, not a file");
  const auto size = fs::file_size(path, ec);
  if (ec) throw IoError(path.string() + ": cannot read size: " + ec.message());
  return size;
}

FilePtr open_or_throw(const fs::path& path, const char* mode) {
  FilePtr f(std::fopen(path.c_str(), mode));
  if (!f) throw IoError(path.string() + ": cannot open: " + std::strerror(errno));
  return f;
}

void read_exactly(std::FILE* f, void* dst, std::size_t n, const std::string& what) {
  const std::size_t got = std::fread(dst, 1, n, f);
  if (got != n) {
    if (std::ferror(f)) throw IoError(what + ": read error: " + std::strerror(errno));
    throw IoError(what + ": file ends early (truncated?)");
  }
}

void write_exactly(std::FILE* f, const void* src, std::size_t n, const std::string& what) {
  if (n && std::fwrite(src, 1, n, f) != n) {
    throw IoError(what + ": write failed: " + std::strerror(errno));
  }
}

void byte_swap_in_place(void* data, std::size_t count, std::size_t element_size) {
  auto* p = static_cast<unsigned char*>(data);
  if (element_size == 2) {
    for (std::size_t i = 0; i < count; ++i, p += 2) std::swap(p[0], p[1]);
  } else if (element_size == 4) {
    for (std::size_t i = 0; i < count; ++i, p += 4) {
      std::swap(p[0], p[3]);
      std::swap(p[1], p[2]);
    }
  }
}

namespace {

class FileRegionSource : public ByteSource {
 public:
  FileRegionSource(FilePtr file, std::uint64_t length, std::string what)
      : file_(std::move(file)), left_(length), what_(std::move(what)) {}
  void read(void* dst, std::size_t n) override {
    if (n > left_) throw IoError(what_ + ": data ends early (truncated?)");
    read_exactly(file_.get(), dst, n, what_);
    left_ -= n;
  }
  std::uint64_t remaining() const override { return left_; }
  void finish() override {}

 private:
  FilePtr file_;
  std::uint64_t left_;
  std::string what_;
};

}  // namespace

std::unique_ptr<ByteSource> file_region_source(const fs::path& path, std::uint64_t offset,
                                               std::uint64_t length, const std::string& what) {
  const std::uint64_t size = file_size_or_throw(path);
  if (offset > size || length > size - offset) {
    throw IoError(what + ": data runs past the end of the file (truncated?)");
  }
  FilePtr f = open_or_throw(path, "rb");
  if (offset && std::fseek(f.get(), static_cast<long>(offset), SEEK_SET) != 0) {
    throw IoError(what + ": cannot seek");
  }
  return std::make_unique<FileRegionSource>(std::move(f), length, what);
}

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::string part;
  for (char c : s) {
    if (c == sep) {
      parts.push_back(part);
      part.clear();
    } else {
      part += c;
    }
  }
  parts.push_back(part);
  return parts;
}

std::string lowercase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string normalize_unit(const std::string& unit) {
  const std::string u = trim(unit);
  const std::string l = lowercase(u);
  if (l == "micron" || l == "microns" || l == "\xc2\xb5m" || l == "\xce\xbcm" || l == "\\u00b5m" ||
      l == "micrometer" || l == "micrometre") {
    return "um";
  }
  if (l == "nanometer" || l == "nanometre") return "nm";
  if (l == "millimeter" || l == "millimetre") return "mm";
  return u;
}

}  // namespace mesorock::voxel
