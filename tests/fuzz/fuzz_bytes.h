#pragma once
// Pieces shared by the fuzz harnesses (tests/fuzz/*_harness.h): a scratch folder for the files the
// loaders read, and a reader that turns fuzz bytes into choices. Header-only, so the normal build's
// regression tests (which replay tests/data/fuzz/) and the libFuzzer targets run the same code.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace mesorock::fuzz {

namespace fs = std::filesystem;

// A folder for this process's scratch files (under TMPDIR; scripts/fuzz.sh points TMPDIR into
// build-fuzz and removes it afterwards).
inline const fs::path& scratch_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("mesorock-fuzz-" + std::to_string(getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

inline fs::path write_scratch(const std::string& name, const void* data, std::size_t size) {
  const fs::path p = scratch_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
  return p;
}

// Consumes fuzz bytes front to back; past the end every read gives zero.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  // A value in [0, n) (n >= 1).
  unsigned pick(unsigned n) { return byte() % n; }
  bool flag() { return byte() & 1u; }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v |= std::uint32_t(byte()) << (8 * k);
    return v;
  }
  double real() {
    std::uint64_t bits = 0;
    for (int k = 0; k < 8; ++k) bits |= std::uint64_t(byte()) << (8 * k);
    double v;
    static_assert(sizeof v == sizeof bits, "double is 64 bits");
    __builtin_memcpy(&v, &bits, sizeof v);
    return v;
  }
  std::size_t left() const { return pos_ < size_ ? size_ - pos_ : 0; }
  const std::uint8_t* rest() const { return data_ + (pos_ < size_ ? pos_ : size_); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace mesorock::fuzz
