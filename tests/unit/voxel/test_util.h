#pragma once
// Helpers for the voxel tests: temporary folders, small volumes, hand-made files (TIFFs written
// directly with libtiff, zip archives written here), and running the rockprep binary.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tiffio.h>
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "support/test_support.h"
#include "voxel/volume.h"

namespace mesorock::voxel::test {

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::run_command;
using mesorock::test::TempDir;
inline std::string read_bytes(const fs::path& path) {
  return mesorock::test::read_file(path);
}

inline bool rocks_available() {
  return fs::is_directory(MESOROCK_ROCKS_DIR);
}
inline fs::path rock(const std::string& name) {
  return fs::path(MESOROCK_ROCKS_DIR) / name;
}
#define SKIP_WITHOUT_ROCKS()                                                                       \
  do {                                                                                             \
    if (!::mesorock::voxel::test::rocks_available())                                               \
      GTEST_SKIP() << "real rock data not found at " MESOROCK_ROCKS_DIR " (../shared/data/rocks)"; \
  } while (0)

// A volume with deterministic pseudo-random content over the dtype's full range.
inline Volume random_volume(const Shape& shape, DType dtype, std::uint64_t seed = 7) {
  Volume v(shape, dtype);
  std::mt19937_64 rng(seed);
  visit_dtype(dtype, [&](auto tag) {
    using T = decltype(tag);
    T* d = v.data<T>();
    for (std::int64_t i = 0; i < v.voxels(); ++i) {
      const std::uint64_t r = rng();
      if (dtype == DType::kBool) {
        d[i] = static_cast<T>(r & 1);
      } else if constexpr (std::is_same_v<T, float>) {
        d[i] = static_cast<float>(static_cast<double>(r >> 11) * 0x1.0p-53 * 2000.0 - 1000.0);
      } else {
        d[i] = static_cast<T>(r);
      }
    }
  });
  return v;
}

inline bool same_voxels(const Volume& a, const Volume& b) {
  return a.shape() == b.shape() && a.dtype() == b.dtype() &&
         std::memcmp(a.bytes(), b.bytes(), a.byte_size()) == 0;
}

inline void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Writes a single-page 8- or 16-bit TIFF directly with libtiff (independent of the code under
// test), value(x, y) per pixel.
template <class ValueFn>
void write_plain_tiff(const fs::path& path, std::uint32_t width, std::uint32_t height, int bits,
                      ValueFn&& value, std::uint16_t compression = COMPRESSION_NONE,
                      std::uint32_t tile = 0, const char* mode = "w") {
  TIFF* tif = TIFFOpen(path.c_str(), mode);
  ASSERT_NE(tif, nullptr);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, width);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, height);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, bits);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, compression);
  const std::size_t bytes = static_cast<std::size_t>(bits / 8);
  if (tile) {
    TIFFSetField(tif, TIFFTAG_TILEWIDTH, tile);
    TIFFSetField(tif, TIFFTAG_TILELENGTH, tile);
    std::vector<unsigned char> buf(tile * tile * bytes);
    for (std::uint32_t ty = 0; ty < height; ty += tile) {
      for (std::uint32_t tx = 0; tx < width; tx += tile) {
        std::fill(buf.begin(), buf.end(), 0);
        for (std::uint32_t y = 0; y < tile; ++y) {
          for (std::uint32_t x = 0; x < tile; ++x) {
            if (tx + x >= width || ty + y >= height) continue;
            const std::uint32_t v = value(tx + x, ty + y);
            std::memcpy(&buf[(y * tile + x) * bytes], &v, bytes);  // little-endian host
          }
        }
        ASSERT_GE(TIFFWriteTile(tif, buf.data(), tx, ty, 0, 0), 0);
      }
    }
  } else {
    TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, 3);
    std::vector<unsigned char> row(width * bytes);
    for (std::uint32_t y = 0; y < height; ++y) {
      for (std::uint32_t x = 0; x < width; ++x) {
        const std::uint32_t v = value(x, y);
        std::memcpy(&row[x * bytes], &v, bytes);
      }
      ASSERT_GE(TIFFWriteScanline(tif, row.data(), y, 0), 0);
    }
  }
  TIFFClose(tif);
}

// A minimal zip writer (stored or deflated members), to make .npz files the way NumPy does,
// including the zip64 extra field NumPy forces on every member.
struct ZipEntry {
  std::string name;
  std::string data;
  bool deflate = false;
  bool zip64_local = false;  // NumPy-style: local sizes 0xFFFFFFFF + zip64 extra
};
// zip64_end: also write the zip64 end-of-central-directory record and locator, with the classic
// record's fields saturated (as archives over 4 GiB or 65535 members have them).
inline std::string make_zip(const std::vector<ZipEntry>& entries, bool zip64_end = false) {
  auto u16 = [](std::string& s, std::uint16_t v) {
    s.push_back(char(v & 0xff));
    s.push_back(char(v >> 8));
  };
  auto u32 = [&](std::string& s, std::uint32_t v) {
    u16(s, std::uint16_t(v & 0xffff));
    u16(s, std::uint16_t(v >> 16));
  };
  auto u64 = [&](std::string& s, std::uint64_t v) {
    u32(s, std::uint32_t(v));
    u32(s, std::uint32_t(v >> 32));
  };
  std::string out, central;
  for (const ZipEntry& e : entries) {
    std::string payload = e.data;
    if (e.deflate) {
      z_stream z{};
      deflateInit2(&z, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
      std::string buf(deflateBound(&z, e.data.size()) + 16, '\0');
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(e.data.data()));
      z.avail_in = static_cast<uInt>(e.data.size());
      z.next_out = reinterpret_cast<Bytef*>(buf.data());
      z.avail_out = static_cast<uInt>(buf.size());
      deflate(&z, Z_FINISH);
      buf.resize(z.total_out);
      deflateEnd(&z);
      payload = buf;
    }
    const std::uint32_t crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(e.data.data()), static_cast<uInt>(e.data.size())));
    const std::uint32_t offset = static_cast<std::uint32_t>(out.size());
    std::string extra;
    if (e.zip64_local) {
      u16(extra, 1);
      u16(extra, 16);
      u64(extra, e.data.size());
      u64(extra, payload.size());
    }
    u32(out, 0x04034b50);
    u16(out, 45);
    u16(out, 0);
    u16(out, e.deflate ? 8 : 0);
    u16(out, 0);
    u16(out, 0x21);
    u32(out, crc);
    u32(out, e.zip64_local ? 0xFFFFFFFFu : std::uint32_t(payload.size()));
    u32(out, e.zip64_local ? 0xFFFFFFFFu : std::uint32_t(e.data.size()));
    u16(out, std::uint16_t(e.name.size()));
    u16(out, std::uint16_t(extra.size()));
    out += e.name + extra + payload;
    u32(central, 0x02014b50);
    u16(central, 45);
    u16(central, 45);
    u16(central, 0);
    u16(central, e.deflate ? 8 : 0);
    u16(central, 0);
    u16(central, 0x21);
    u32(central, crc);
    u32(central, std::uint32_t(payload.size()));
    u32(central, std::uint32_t(e.data.size()));
    u16(central, std::uint16_t(e.name.size()));
    u16(central, 0);
    u16(central, 0);
    u16(central, 0);
    u16(central, 0);
    u32(central, 0);
    u32(central, offset);
    central += e.name;
  }
  const std::uint32_t cd_offset = static_cast<std::uint32_t>(out.size());
  out += central;
  if (zip64_end) {
    const std::uint64_t record = out.size();
    u32(out, 0x06064b50);
    u64(out, 44);
    u16(out, 45);
    u16(out, 45);
    u32(out, 0);
    u32(out, 0);
    u64(out, entries.size());
    u64(out, entries.size());
    u64(out, central.size());
    u64(out, cd_offset);
    u32(out, 0x07064b50);
    u32(out, 0);
    u64(out, record);
    u32(out, 1);
  }
  u32(out, 0x06054b50);
  u16(out, 0);
  u16(out, 0);
  u16(out, zip64_end ? 0xFFFF : std::uint16_t(entries.size()));
  u16(out, zip64_end ? 0xFFFF : std::uint16_t(entries.size()));
  u32(out, zip64_end ? 0xFFFFFFFFu : std::uint32_t(central.size()));
  u32(out, zip64_end ? 0xFFFFFFFFu : cd_offset);
  u16(out, 0);
  return out;
}

inline std::string rockprep() {
  return std::string("\"") + MESOROCK_ROCKPREP + "\"";
}

// The non-empty lines of a text.
inline std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream s(text);
  std::string line;
  while (std::getline(s, line)) {
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

// Nothing but the inputs the test made may be left in `dir` (no outputs, no ".partial" files).
inline void expect_only(const fs::path& dir, std::vector<std::string> expected) {
  std::vector<std::string> found;
  for (const auto& e : fs::directory_iterator(dir)) found.push_back(e.path().filename().string());
  std::sort(found.begin(), found.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(found, expected);
}

// Runs rockprep in `tmp` expecting exit code 2 and a single "rockprep: error: ..." line that
// contains `needle` (usually the file the error is about).
inline void expect_bad_input(const TempDir& tmp, const std::string& args,
                             const std::string& needle) {
  const CommandResult r =
      run_command("cd " + tmp.path().string() + " && " + rockprep() + " " + args, tmp.path());
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
  const std::vector<std::string> err = lines(r.err);
  ASSERT_EQ(err.size(), 1u) << args << "\n" << r.err;
  EXPECT_EQ(err[0].rfind("rockprep: error: ", 0), 0u) << err[0];
  EXPECT_NE(err[0].find(needle), std::string::npos)
      << "error does not name " << needle << ": " << err[0];
}

}  // namespace mesorock::voxel::test
