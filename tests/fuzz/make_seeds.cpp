// Writes the fuzz targets' seed corpora into DIR/<target>/: small volumes written by the project's
// own writers (TIFF, npy), zip archives of npy arrays (stored and deflated, as np.savez and
// np.savez_compressed write them), MetaImage headers and raw files. Scene seeds are the repo's
// scene files (copied by scripts/fuzz.sh). Usage: fuzz_make_seeds DIR
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "voxel/npy_io.h"
#include "voxel/tiff_io.h"
#include "voxel/volume.h"
#include "voxel_harness.h"

namespace fs = std::filesystem;
namespace mv = mesorock::voxel;

namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_bytes(const fs::path& p, const Bytes& b) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

void write_text(const fs::path& p, const std::string& s) {
  write_bytes(p, Bytes(s.begin(), s.end()));
}

mv::Volume sample(mv::DType dtype, mv::Shape shape) {
  mv::Volume v(shape, dtype, mv::Spacing{2.5, 1.25, 1.25, "nm"});
  for (std::int64_t i = 0; i < v.voxels(); ++i) {
    std::byte* b = v.bytes() + static_cast<std::size_t>(i) * mv::dtype_size(dtype);
    mv::visit_dtype(dtype, [&](auto tag) {
      using T = decltype(tag);
      T value = dtype == mv::DType::kBool ? T(i % 2) : T(i * 3 % 50);
      std::memcpy(b, &value, sizeof value);
    });
  }
  return v;
}

void put16(Bytes& b, unsigned v) {
  b.push_back(static_cast<std::uint8_t>(v));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
void put32(Bytes& b, std::uint32_t v) {
  put16(b, v & 0xffffu);
  put16(b, v >> 16);
}

// A one-member zip archive holding `data` as `name`, stored or raw-deflated.
Bytes zip_of(const std::string& name, const Bytes& data, bool compressed) {
  Bytes body = data;
  if (compressed) {
    z_stream z{};
    deflateInit2(&z, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
    body.assign(deflateBound(&z, data.size()), 0);
    z.next_in = const_cast<Bytef*>(data.data());
    z.avail_in = static_cast<uInt>(data.size());
    z.next_out = body.data();
    z.avail_out = static_cast<uInt>(body.size());
    deflate(&z, Z_FINISH);
    body.resize(z.total_out);
    deflateEnd(&z);
  }
  const std::uint32_t crc =
      static_cast<std::uint32_t>(crc32(0, data.data(), static_cast<uInt>(data.size())));
  Bytes out;
  auto header = [&](bool central) {
    put32(out, central ? 0x02014b50u : 0x04034b50u);
    if (central) put16(out, 20);
    put16(out, 20);
    put16(out, 0);
    put16(out, compressed ? 8 : 0);
    put16(out, 0);
    put16(out, 0);
    put32(out, crc);
    put32(out, static_cast<std::uint32_t>(body.size()));
    put32(out, static_cast<std::uint32_t>(data.size()));
    put16(out, static_cast<unsigned>(name.size()));
    put16(out, 0);
    if (central) {
      put16(out, 0);
      put16(out, 0);
      put16(out, 0);
      put32(out, 0);
      put32(out, 0);  // local header offset
    }
    out.insert(out.end(), name.begin(), name.end());
  };
  header(false);
  out.insert(out.end(), body.begin(), body.end());
  const std::uint32_t central_at = static_cast<std::uint32_t>(out.size());
  header(true);
  const std::uint32_t central_size = static_cast<std::uint32_t>(out.size()) - central_at;
  put32(out, 0x06054b50u);
  put16(out, 0);
  put16(out, 0);
  put16(out, 1);
  put16(out, 1);
  put32(out, central_size);
  put32(out, central_at);
  put16(out, 0);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_make_seeds DIR\n";
    return 2;
  }
  const fs::path root = argv[1];
  for (const char* t : {"tiff", "npy", "npz", "mhd", "raw", "hdf5", "scene"})
    fs::create_directories(root / t);
  const fs::path scratch = root / "scratch";
  fs::create_directories(scratch);

  const mv::DType dtypes[] = {mv::DType::kBool, mv::DType::kInt8, mv::DType::kUInt8,
                              mv::DType::kUInt16, mv::DType::kFloat32};
  int k = 0;
  for (mv::DType d : dtypes) {
    const mv::Volume v = sample(d, {2, 3, 4});
    const std::string stem = std::string(mv::dtype_name(d));
    // TIFF: one multi-page file (prefix byte 0), plain and deflated; two equal one-page slices
    // (prefix byte 1: the harness splits the rest at its middle).
    for (bool deflate : {false, true}) {
      mv::TiffWriteOptions o;
      o.deflate = deflate;
      const fs::path tif = scratch / "v.tif";
      mv::write_tiff_file(v, tif, o, "seed");
      Bytes seed{0};
      const Bytes file = read_bytes(tif);
      seed.insert(seed.end(), file.begin(), file.end());
      write_bytes(root / "tiff" / (stem + (deflate ? "_deflate" : "") + ".bin"), seed);
    }
    {
      const mv::Volume slice = sample(d, {1, 3, 4});
      const fs::path tif = scratch / "s.tif";
      mv::write_tiff_file(slice, tif, {}, "seed");
      const Bytes file = read_bytes(tif);
      Bytes seed{1};
      seed.insert(seed.end(), file.begin(), file.end());
      seed.insert(seed.end(), file.begin(), file.end());
      write_bytes(root / "tiff" / (stem + "_folder.bin"), seed);
    }
    // npy in C and Fortran order; npz stored and deflated.
    for (bool fortran : {false, true}) {
      const fs::path npy = root / "npy" / (stem + (fortran ? "_f" : "") + ".npy");
      mv::write_npy(v, npy, fortran);
      if (!fortran)
        for (bool deflate : {false, true})
          write_bytes(root / "npz" / (stem + (deflate ? "_deflate" : "") + ".npz"),
                      zip_of("im.npy", read_bytes(npy), deflate));
    }
    // raw: shape 2 x 3 x 4 (bytes 2, 3, 4), dtype, byte order, no header bytes, then the data.
    Bytes raw{2, 3, 4, static_cast<std::uint8_t>(d), static_cast<std::uint8_t>(k % 2), 0};
    raw.insert(raw.end(), reinterpret_cast<const std::uint8_t*>(v.bytes()),
               reinterpret_cast<const std::uint8_t*>(v.bytes()) + v.byte_size());
    write_bytes(root / "raw" / (stem + ".bin"), raw);
    ++k;
  }
  // MetaImage: the external companion file the harness provides (data.raw, 4 KiB), inline data,
  // inline zlib data, and a sidecar after the "@json" marker.
  const std::string common =
      "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      "ElementSpacing = 1.25 1.25 2.5\n";
  const std::string small = common + "DimSize = 4 3 2\n";
  write_text(root / "mhd" / "external.mhd",
             common + "DimSize = 16 16 16\nElementType = MET_UCHAR\nElementDataFile = data.raw\n");
  write_text(root / "mhd" / "external_u16.mhd",
             common + "DimSize = 16 16 8\nElementType = MET_USHORT\nElementDataFile = data.raw\n");
  write_text(root / "mhd" / "external_tail.mhd",
             common + "DimSize = 8 8 8\nHeaderSize = -1\nElementType = MET_CHAR\n" +
                 "ElementDataFile = data.raw\n");
  write_text(root / "mhd" / "sidecar.mhd",
             common + "DimSize = 16 16 16\nElementType = MET_UCHAR\nElementDataFile = data.raw\n" +
                 "\n@json\n{\"generator\": \"mesorock\", \"unit\": \"nm\", \"dtype\": \"bool\"}");
  {
    std::string inline_text = small + "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n";
    Bytes b(inline_text.begin(), inline_text.end());
    for (int i = 0; i < 24; ++i) b.push_back(static_cast<std::uint8_t>(i));
    write_bytes(root / "mhd" / "local.mha", b);
    Bytes data(24);
    for (int i = 0; i < 24; ++i) data[static_cast<size_t>(i)] = static_cast<std::uint8_t>(i);
    Bytes packed(compressBound(24));
    uLongf packed_size = packed.size();
    compress2(packed.data(), &packed_size, data.data(), 24, 6);
    packed.resize(packed_size);
    const std::string z = small + "ElementType = MET_UCHAR\nCompressedData = True\n" +
                          "CompressedDataSize = " + std::to_string(packed_size) +
                          "\nElementDataFile = LOCAL\n";
    Bytes c(z.begin(), z.end());
    c.insert(c.end(), packed.begin(), packed.end());
    write_bytes(root / "mhd" / "local_zlib.mha", c);
  }
  // HDF5: the harness builds the file from choices, so any bytes are a seed; a few lengths.
  for (int n : {8, 64, 256}) {
    Bytes b(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) b[static_cast<size_t>(i)] = static_cast<std::uint8_t>(i * 37 + n);
    write_bytes(root / "hdf5" / ("bytes_" + std::to_string(n) + ".bin"), b);
  }
  fs::remove_all(scratch);
  // Every seed must load: a seed the loader refuses would start the fuzzer in the error paths.
  int refused = 0;
  const std::pair<const char*, void (*)(const std::uint8_t*, std::size_t)> harnesses[] = {
      {"tiff", mesorock::fuzz::fuzz_tiff},
      {"npy", mesorock::fuzz::fuzz_npy},
      {"npz", mesorock::fuzz::fuzz_npz},
      {"mhd", mesorock::fuzz::fuzz_mhd},
      {"raw", mesorock::fuzz::fuzz_raw}};
  for (const auto& [target, harness] : harnesses)
    for (const auto& entry : fs::directory_iterator(root / target)) {
      const Bytes b = read_bytes(entry.path());
      harness(b.data(), b.size());
      if (!mesorock::fuzz::last_refusal().empty()) {
        std::cerr << "fuzz_make_seeds: seed " << entry.path().string()
                  << " is refused: " << mesorock::fuzz::last_refusal() << "\n";
        ++refused;
      }
    }
  if (refused > 0) return 1;
  std::cout << "fuzz_make_seeds: seeds in " << root.string() << "\n";
  return 0;
}
