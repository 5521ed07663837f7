#pragma once
// A 64-bit checksum of bytes, for checkpoints (each dataset's, checked on resume) and for the
// files a scene names (a solid grid or particle file replaced between an interrupt and the
// resume). Written here rather than taken from a library (no new dependency).
//
// Words of 8 bytes are mixed in one at a time by steps that are each a bijection of the running
// state (xor with an odd multiple of the word, rotate, multiply by an odd constant), so two
// inputs of one length that differ in one word, any bits of it, never give one sum; the length
// and the tail bytes are mixed in last. Not a cryptographic hash: it finds damage, not forgery.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mesorock/errors.h"

namespace mesorock {

class Checksum {
 public:
  void add(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    length_ += bytes;
    // Finish a word begun by the last call first.
    while (bytes > 0 && pending_ > 0) {
      word_ |= std::uint64_t{*p++} << (8 * pending_);
      --bytes;
      if (++pending_ == 8) mix(), pending_ = 0;
    }
    for (; bytes >= 8; bytes -= 8, p += 8) {
      std::memcpy(&word_, p, 8);
      mix();
    }
    for (; bytes > 0; --bytes) word_ |= std::uint64_t{*p++} << (8 * pending_++);
  }
  std::uint64_t value() const {
    std::uint64_t h = state_;
    if (pending_ > 0) h = step(h, word_);
    h = step(h, length_);
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    return h;
  }
  // 16 lower-case hex digits.
  std::string hex() const { return to_hex(value()); }

  static std::string to_hex(std::uint64_t v) {
    static const char digits[] = "0123456789abcdef";
    std::string s(16, '0');
    for (int k = 15; k >= 0; --k, v >>= 4) s[static_cast<std::size_t>(k)] = digits[v & 15];
    return s;
  }

 private:
  static constexpr std::uint64_t kPrime1 = 0x9e3779b185ebca87ULL;
  static constexpr std::uint64_t kPrime2 = 0xc2b2ae3d27d4eb4fULL;
  static std::uint64_t step(std::uint64_t h, std::uint64_t w) {
    h ^= w * kPrime2;
    h = (h << 31) | (h >> 33);
    return h * kPrime1;
  }
  void mix() {
    state_ = step(state_, word_);
    word_ = 0;
  }
  std::uint64_t state_ = 0x27d4eb2f165667c5ULL;
  std::uint64_t word_ = 0;
  std::uint64_t length_ = 0;
  unsigned pending_ = 0;
};

inline std::string checksum_hex(const void* data, std::size_t bytes) {
  Checksum c;
  c.add(data, bytes);
  return c.hex();
}

template <class T>
std::string checksum_hex(const std::vector<T>& v) {
  return checksum_hex(v.data(), v.size() * sizeof(T));
}

// The checksum of a file's bytes; IoError naming it when it cannot be read.
inline std::string file_checksum_hex(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path.string() + ": cannot open for reading");
  Checksum c;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    c.add(buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw IoError(path.string() + ": read failed");
  return c.hex();
}

}  // namespace mesorock
