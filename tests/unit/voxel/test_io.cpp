// Loaders and writers: TIFF folders and files, raw, MetaImage, NumPy, HDF5, format detection.
#include <gtest/gtest.h>

#include <hdf5.h>

#include <algorithm>

#include "mesorock/errors.h"
#include "test_util.h"
#include "voxel/hdf5_io.h"
#include "voxel/load.h"
#include "voxel/npy_io.h"
#include "voxel/raw_io.h"
#include "voxel/staged_output.h"
#include "voxel/tiff_io.h"

namespace mesorock::voxel::test {
namespace {

const DType kAllTypes[] = {DType::kBool, DType::kInt8, DType::kUInt8, DType::kUInt16,
                           DType::kFloat32};

// Expects `fn` to throw E whose message contains every string in `parts`, on one line.
template <class E, class Fn>
void expect_error(Fn&& fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception; expected one mentioning " << parts.front();
  } catch (const E& e) {
    const std::string what = e.what();
    for (const std::string& p : parts) EXPECT_NE(what.find(p), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "multi-line message: " << what;
  }
}

TEST(NaturalSort, NumbersCompareByValue) {
  std::vector<std::string> names = {"s_10.tif", "s_2.tif",   "s_1.tif",  "s_007.tif",
                                    "a.tif",    "s_100.tif", "s_9b.tif", "s_9a.tif"};
  std::sort(names.begin(), names.end(), natural_less);
  const std::vector<std::string> expected = {"a.tif",    "s_1.tif",  "s_2.tif",  "s_007.tif",
                                             "s_9a.tif", "s_9b.tif", "s_10.tif", "s_100.tif"};
  EXPECT_EQ(names, expected);
}

TEST(TiffFolder, RoundTripsEveryDtypeWithSpacing) {
  for (DType dtype : kAllTypes) {
    TempDir tmp;
    Volume v = random_volume({5, 7, 11}, dtype);
    v.set_spacing({5.0, 2.5, 2.0, "nm"});
    {
      StagedOutputs out = StagedOutputs::in_directory(tmp / "stack");
      EXPECT_EQ(write_tiff_slices(v, out, "", {}), 5u);
      out.commit();
    }
    ReadReport report;
    const Volume back = read_tiff_folder(tmp / "stack", {}, &report);
    EXPECT_TRUE(same_voxels(v, back)) << dtype_name(dtype);
    EXPECT_EQ(report.spacing_source, "metadata");
    EXPECT_DOUBLE_EQ(back.spacing().dz, 5.0);
    EXPECT_NEAR(back.spacing().dy, 2.5, 1e-6);
    EXPECT_NEAR(back.spacing().dx, 2.0, 1e-6);
    EXPECT_EQ(back.spacing().unit, "nm");
  }
}

TEST(TiffFolder, SlicesAreStackedInNaturalOrder) {
  TempDir tmp;
  fs::create_directory(tmp / "stack");
  // Lexicographic order would put slice_10 before slice_2.
  for (int z : {1, 2, 10}) {
    write_plain_tiff(tmp / "stack" / ("slice_" + std::to_string(z) + ".tif"), 4, 3, 8,
                     [z](std::uint32_t, std::uint32_t) { return std::uint32_t(z); });
  }
  write_bytes(tmp / "stack" / "notes.txt", "not a slice");
  const Volume v = read_tiff_folder(tmp / "stack");
  ASSERT_EQ(v.shape(), (Shape{3, 3, 4}));
  EXPECT_EQ(v.slice<std::uint8_t>(0)[0], 1);
  EXPECT_EQ(v.slice<std::uint8_t>(1)[0], 2);
  EXPECT_EQ(v.slice<std::uint8_t>(2)[0], 10);
}

TEST(TiffFile, ReadsStripsTilesAndCompressionWrittenByLibtiff) {
  TempDir tmp;
  // 22 rows in strips of 3 and 16x16 tiles: the last strip and the edge tiles are partial.
  auto pattern = [](std::uint32_t x, std::uint32_t y) { return (x * 7 + y * 13) % 65536; };
  struct Case {
    std::uint16_t compression;
    std::uint32_t tile;
    const char* mode;  // "wb": big-endian file
  };
  for (const Case c : {Case{COMPRESSION_NONE, 0, "w"}, Case{COMPRESSION_LZW, 0, "w"},
                       Case{COMPRESSION_ADOBE_DEFLATE, 0, "w"}, Case{COMPRESSION_PACKBITS, 0, "w"},
                       Case{COMPRESSION_NONE, 16, "w"}, Case{COMPRESSION_ADOBE_DEFLATE, 16, "w"},
                       Case{COMPRESSION_NONE, 0, "wb"}, Case{COMPRESSION_LZW, 16, "wb"}}) {
    const fs::path file = tmp / ("p" + std::to_string(c.compression) + "_" +
                                 std::to_string(c.tile) + c.mode + ".tif");
    write_plain_tiff(file, 37, 22, 16, pattern, c.compression, c.tile, c.mode);
    ReadReport report;
    const Volume v = read_tiff_file(file, {}, &report);
    ASSERT_EQ(v.shape(), (Shape{1, 22, 37}));
    ASSERT_EQ(v.dtype(), DType::kUInt16);
    EXPECT_EQ(report.spacing_source, "none");
    EXPECT_FALSE(v.spacing().known());
    bool all_equal = true;
    for (std::uint32_t y = 0; y < 22; ++y) {
      for (std::uint32_t x = 0; x < 37; ++x) {
        all_equal &= v.data<std::uint16_t>()[y * 37 + x] == pattern(x, y);
      }
    }
    EXPECT_TRUE(all_equal) << "compression " << c.compression << " tile " << c.tile << " "
                           << c.mode;
  }
}

TEST(TiffFile, MultiPageRoundTripCompressed) {
  TempDir tmp;
  for (DType dtype : kAllTypes) {
    const Volume v = random_volume({6, 9, 13}, dtype, 11);
    TiffWriteOptions options;
    options.deflate = true;
    write_tiff_file(v, tmp / "multi.tif", options);
    const Volume back = read_tiff_file(tmp / "multi.tif");
    EXPECT_TRUE(same_voxels(v, back)) << dtype_name(dtype);
  }
}

TEST(TiffFolder, SlicesOfDifferentSizeOrTypeAreRefusedNamingBoth) {
  TempDir tmp;
  fs::create_directory(tmp / "size");
  auto zero = [](std::uint32_t, std::uint32_t) { return 0u; };
  write_plain_tiff(tmp / "size" / "slice_000.tif", 8, 8, 16, zero);
  write_plain_tiff(tmp / "size" / "slice_001.tif", 8, 8, 16, zero);
  write_plain_tiff(tmp / "size" / "slice_002.tif", 8, 7, 16, zero);
  expect_error<IoError>([&] { read_tiff_folder(tmp / "size"); },
                        {"slice_002.tif", "8x7", "slice_000.tif", "8x8", "uint16"});
  fs::create_directory(tmp / "type");
  write_plain_tiff(tmp / "type" / "a1.tif", 8, 8, 16, zero);
  write_plain_tiff(tmp / "type" / "a2.tif", 8, 8, 8, zero);
  expect_error<IoError>([&] { read_tiff_folder(tmp / "type"); }, {"a2.tif", "uint8", "uint16"});
}

TEST(TiffFolder, EmptyFolderAndBrokenSlicesAreRefused) {
  TempDir tmp;
  fs::create_directory(tmp / "empty");
  expect_error<IoError>([&] { read_tiff_folder(tmp / "empty"); }, {"empty", "no .tif"});

  fs::create_directory(tmp / "garbage");
  write_plain_tiff(tmp / "garbage" / "s0.tif", 8, 8, 8, [](auto, auto) { return 1u; });
  write_bytes(tmp / "garbage" / "s1.tif", "this is not a TIFF file at all, just text");
  expect_error<IoError>([&] { read_tiff_folder(tmp / "garbage"); }, {"s1.tif"});

  // Truncated: the pixel data of a valid slice cut short.
  fs::create_directory(tmp / "cut");
  write_plain_tiff(tmp / "cut" / "s0.tif", 64, 64, 8, [](auto, auto) { return 1u; });
  write_plain_tiff(tmp / "cut" / "s1.tif", 64, 64, 8, [](auto, auto) { return 1u; });
  const std::string whole = read_bytes(tmp / "cut" / "s1.tif");
  // libtiff writes the directory after the data; keep the header, drop the rest.
  write_bytes(tmp / "cut" / "s1.tif", whole.substr(0, whole.size() / 2));
  expect_error<IoError>([&] { read_tiff_folder(tmp / "cut"); }, {"s1.tif"});
}

// A classic little-endian TIFF with its directory first and one uncompressed 8-bit strip after
// it (the layout tifffile writes), so truncation cuts pixel data, not the directory.
std::string directory_first_tiff(std::uint32_t width, std::uint32_t height,
                                 std::uint32_t strip_bytes, const std::string& pixels) {
  std::string t;
  auto u16 = [&](std::uint16_t v) {
    t.push_back(char(v & 0xff));
    t.push_back(char(v >> 8));
  };
  auto u32 = [&](std::uint32_t v) {
    u16(std::uint16_t(v & 0xffff));
    u16(std::uint16_t(v >> 16));
  };
  const std::uint16_t entries = 9;
  const std::uint32_t data_offset = 8 + 2 + 12 * entries + 4;
  auto entry = [&](std::uint16_t tag, std::uint16_t type, std::uint32_t value) {
    u16(tag);
    u16(type);
    u32(1);
    if (type == 3) {
      u16(std::uint16_t(value));
      u16(0);
    } else {
      u32(value);
    }
  };
  t += "II";
  u16(42);
  u32(8);
  u16(entries);
  entry(256, 4, width);
  entry(257, 4, height);
  entry(258, 3, 8);
  entry(259, 3, 1);
  entry(262, 3, 1);
  entry(273, 4, data_offset);
  entry(277, 3, 1);
  entry(278, 4, height);
  entry(279, 4, strip_bytes);
  u32(0);
  return t + pixels;
}

TEST(TiffFile, DirectoryFirstLayoutReadsAndTruncationIsCaught) {
  TempDir tmp;
  std::string pixels(8 * 8, '\0');
  for (int i = 0; i < 64; ++i) pixels[i] = char(i);
  write_bytes(tmp / "ok.tif", directory_first_tiff(8, 8, 64, pixels));
  const Volume v = read_tiff_file(tmp / "ok.tif");
  ASSERT_EQ(v.shape(), (Shape{1, 8, 8}));
  EXPECT_EQ(v.data<std::uint8_t>()[63], 63);
  write_bytes(tmp / "cut.tif", directory_first_tiff(8, 8, 64, pixels.substr(0, 40)));
  expect_error<IoError>([&] { read_tiff_file(tmp / "cut.tif"); }, {"cut.tif", "truncated"});
}

TEST(TiffFile, AbsurdHeaderSizeIsRefusedBeforeAllocating) {
  TempDir tmp;
  // 60000 x 60000 pixels (3.6 GB) claimed, 64 bytes of pixel data held. (libtiff itself
  // re-estimates a too-small single uncompressed strip, so the message may be about the strip
  // running past the end of the file rather than about the byte count.)
  write_bytes(tmp / "absurd.tif", directory_first_tiff(60000, 60000, 64, std::string(64, '\1')));
  expect_error<IoError>([&] { read_tiff_file(tmp / "absurd.tif"); }, {"absurd.tif"});
  // Deflate-compressed: 64 bytes cannot inflate to 3.6 GB.
  std::string deflated = directory_first_tiff(60000, 60000, 64, std::string(64, '\1'));
  deflated[8 + 2 + 12 * 3 + 8] = 8;  // Compression (4th entry) = Adobe Deflate
  write_bytes(tmp / "deflated.tif", deflated);
  expect_error<IoError>([&] { read_tiff_file(tmp / "deflated.tif"); },
                        {"deflated.tif", "60000x60000", "holds only 64 bytes"});
  write_bytes(tmp / "past.tif",
              directory_first_tiff(60000, 60000, 60000u * 60000u, std::string(64, '\1')));
  expect_error<IoError>([&] { read_tiff_file(tmp / "past.tif"); }, {"past.tif", "truncated"});
}

TEST(Raw, ReadsExactSizeAndBothByteOrders) {
  TempDir tmp;
  const Volume v = random_volume({4, 5, 6}, DType::kUInt16);
  write_raw(v, tmp / "v.raw", "v.raw");
  RawOptions o;
  o.shape = {4, 5, 6};
  o.dtype = DType::kUInt16;
  EXPECT_TRUE(same_voxels(v, read_raw(tmp / "v.raw", o)));
  // Big-endian copy.
  std::string bytes = read_bytes(tmp / "v.raw");
  for (std::size_t i = 0; i + 1 < bytes.size(); i += 2) std::swap(bytes[i], bytes[i + 1]);
  write_bytes(tmp / "be.raw", bytes);
  o.big_endian = true;
  EXPECT_TRUE(same_voxels(v, read_raw(tmp / "be.raw", o)));
}

TEST(Raw, SizeDisagreeingWithShapeIsRefused) {
  TempDir tmp;
  write_bytes(tmp / "short.raw", std::string(100, '\0'));
  RawOptions o;
  o.shape = {2, 10, 10};
  o.dtype = DType::kUInt8;
  expect_error<IoError>([&] { read_raw(tmp / "short.raw", o); },
                        {"short.raw", "100 bytes", "2x10x10", "200 bytes"});
  write_bytes(tmp / "long.raw", std::string(300, '\0'));
  expect_error<IoError>([&] { read_raw(tmp / "long.raw", o); }, {"long.raw", "300 bytes"});
}

TEST(MetaImage, RoundTripKeepsSpacingUnitAndBool) {
  for (DType dtype : kAllTypes) {
    TempDir tmp;
    Volume v = random_volume({3, 4, 5}, dtype);
    v.set_spacing({5, 2.5, 2.5, "nm"});
    {
      StagedOutputs out = StagedOutputs::files();
      write_mhd(v, out, tmp / "v.mhd", {{"note", "test"}});
      out.commit();
    }
    ReadReport report;
    const Volume back = read_mhd(tmp / "v.mhd", {}, &report);
    EXPECT_TRUE(same_voxels(v, back)) << dtype_name(dtype);
    EXPECT_EQ(back.spacing().str(), v.spacing().str());
    EXPECT_EQ(report.provenance.value("note", ""), "test");
    EXPECT_TRUE(report.warnings.empty());
  }
}

TEST(MetaImage, ForeignHeadersLocalCompressedAndBigEndian) {
  TempDir tmp;
  const Volume v = random_volume({3, 4, 5}, DType::kUInt16);
  const std::string data(reinterpret_cast<const char*>(v.bytes()), v.byte_size());
  // .mha with the data after the header (ElementDataFile = LOCAL).
  write_bytes(tmp / "a.mha",
              "ObjectType = Image\nNDims = 3\nDimSize = 5 4 3\nElementType = MET_USHORT\n"
              "ElementSpacing = 0.5 0.5 1\nElementDataFile = LOCAL\n" +
                  data);
  ReadReport report;
  Volume back = read_mhd(tmp / "a.mha", {}, &report);
  EXPECT_TRUE(same_voxels(v, back));
  EXPECT_EQ(back.spacing().unit, "mm");  // MetaImage has no unit: ITK's mm, with a warning
  EXPECT_EQ(report.warnings.size(), 1u);
  EXPECT_DOUBLE_EQ(back.spacing().dz, 1.0);
  // zlib-compressed external data.
  std::string packed(compressBound(static_cast<uLong>(data.size())), '\0');
  uLongf packed_size = static_cast<uLongf>(packed.size());
  compress(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
           reinterpret_cast<const Bytef*>(data.data()), static_cast<uLong>(data.size()));
  packed.resize(packed_size);
  write_bytes(tmp / "c.zraw", packed);
  write_bytes(tmp / "c.mhd",
              "ObjectType = Image\nNDims = 3\nDimSize = 5 4 3\nElementType = MET_USHORT\n"
              "CompressedData = True\nCompressedDataSize = " +
                  std::to_string(packed.size()) + "\nElementDataFile = c.zraw\n");
  EXPECT_TRUE(same_voxels(v, read_mhd(tmp / "c.mhd")));
  // Big-endian data.
  std::string swapped = data;
  for (std::size_t i = 0; i + 1 < swapped.size(); i += 2) std::swap(swapped[i], swapped[i + 1]);
  write_bytes(tmp / "b.raw", swapped);
  write_bytes(tmp / "b.mhd",
              "NDims = 3\nDimSize = 5 4 3\nElementType = MET_USHORT\nBinaryDataByteOrderMSB = "
              "True\nElementDataFile = b.raw\n");
  EXPECT_TRUE(same_voxels(v, read_mhd(tmp / "b.mhd")));
}

TEST(MetaImage, OurSidecarWithAFieldOfTheWrongKindIsRefusedNamingIt) {
  TempDir tmp;
  write_bytes(tmp / "v.raw", std::string(60, '\0'));
  write_bytes(tmp / "v.mhd",
              "NDims = 3\nDimSize = 5 4 3\nElementType = MET_UCHAR\nElementDataFile = v.raw\n");
  // A type error deep in nlohmann::json was what the MetaImage fuzzer found (tests/data/fuzz/mhd).
  const std::pair<const char*, const char*> damaged[] = {
      {R"({"generator": "mesorock", "dtype": 3})", "'dtype' must be a string"},
      {R"({"generator": "mesorock", "unit": [1]})", "'unit' must be a string"},
      {R"({"generator": "mesorock", "origin_zyx": ["a", 0, 0]})", "'origin_zyx' must be three"},
      {R"({"generator": "mesorock", "origin_zyx": [0, 0]})", "'origin_zyx' must be three"}};
  for (const auto& [text, message] : damaged) {
    write_bytes(tmp / "v.json", text);
    expect_error<IoError>([&] { read_mhd(tmp / "v.mhd"); }, {"v.json", message});
  }
  // A sidecar that is not ours (another generator, or not an object) is ignored, as before.
  for (const char* text : {R"({"generator": 7, "dtype": 3})", R"(["generator", "mesorock"])"}) {
    write_bytes(tmp / "v.json", text);
    EXPECT_EQ(read_mhd(tmp / "v.mhd").dtype(), DType::kUInt8) << text;
  }
}

TEST(MetaImage, DataSizeDisagreeingWithHeaderIsRefused) {
  TempDir tmp;
  write_bytes(tmp / "v.raw", std::string(59, '\0'));
  write_bytes(tmp / "v.mhd",
              "NDims = 3\nDimSize = 5 4 3\nElementType = MET_UCHAR\nElementDataFile = v.raw\n");
  expect_error<IoError>([&] { read_mhd(tmp / "v.mhd"); }, {"v.raw", "59 bytes", "v.mhd", "60"});
  // An absurd header: 10^5 cubed floats (4 PB) for a 59-byte file, refused before allocating.
  write_bytes(tmp / "huge.mhd",
              "NDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_FLOAT\n"
              "ElementDataFile = v.raw\n");
  expect_error<IoError>([&] { read_mhd(tmp / "huge.mhd"); }, {"huge.mhd"});
  write_bytes(tmp / "overflow.mhd",
              "NDims = 3\nDimSize = 4000000000 4000000000 4000000000\nElementType = MET_FLOAT\n"
              "ElementDataFile = v.raw\n");
  expect_error<IoError>([&] { read_mhd(tmp / "overflow.mhd"); }, {"overflow.mhd"});
  // A compressed file claiming more than deflate can expand to.
  write_bytes(tmp / "z.mhd",
              "NDims = 3\nDimSize = 1000 1000 1000\nElementType = MET_UCHAR\nCompressedData = "
              "True\nElementDataFile = v.raw\n");
  expect_error<IoError>([&] { read_mhd(tmp / "z.mhd"); }, {"z.mhd", "v.raw"});
}

TEST(Npy, EveryDtypeInCAndFortranOrder) {
  TempDir tmp;
  for (DType dtype : kAllTypes) {
    for (bool fortran : {false, true}) {
      const Volume v = random_volume({3, 5, 7}, dtype, 3);
      write_npy(v, tmp / "a.npy", fortran);
      const Volume back = read_npy(tmp / "a.npy");
      EXPECT_TRUE(same_voxels(v, back)) << dtype_name(dtype) << (fortran ? " F" : " C");
    }
  }
}

TEST(Npy, FortranOrderFileMadeByHandMatchesNumpyLayout) {
  TempDir tmp;
  // np.arange(24, dtype=np.uint8).reshape(2,3,4) saved with order='F': element (i,j,k) holds
  // 12i + 4j + k and sits at byte i + 2 (j + 3 k).
  std::string dict = "{'descr': '|u1', 'fortran_order': True, 'shape': (2, 3, 4), }";
  while ((10 + dict.size() + 1) % 64) dict += ' ';
  dict += '\n';
  std::string file = std::string("\x93NUMPY\x01\x00", 8) + char(dict.size()) + char(0) + dict;
  std::string data(24, '\0');
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 4; ++k) data[i + 2 * (j + 3 * k)] = char(12 * i + 4 * j + k);
  write_bytes(tmp / "f.npy", file + data);
  const Volume v = read_npy(tmp / "f.npy");
  ASSERT_EQ(v.shape(), (Shape{2, 3, 4}));
  for (int i = 0; i < 24; ++i) EXPECT_EQ(v.data<std::uint8_t>()[i], i);
}

TEST(Npy, BigEndianAndBadHeaders) {
  TempDir tmp;
  std::string dict = "{'descr': '>u2', 'fortran_order': False, 'shape': (1, 1, 3), }";
  dict += '\n';
  write_bytes(tmp / "be.npy", std::string("\x93NUMPY\x01\x00", 8) + char(dict.size()) + char(0) +
                                  dict + std::string("\x01\x02\x00\x03\xff\x00", 6));
  const Volume v = read_npy(tmp / "be.npy");
  EXPECT_EQ(v.data<std::uint16_t>()[0], 0x0102);
  EXPECT_EQ(v.data<std::uint16_t>()[1], 0x0003);
  EXPECT_EQ(v.data<std::uint16_t>()[2], 0xff00);
  // Header claims 1000^3 voxels; the file holds 6 bytes.
  std::string big = "{'descr': '|u1', 'fortran_order': False, 'shape': (1000, 1000, 1000), }\n";
  write_bytes(tmp / "big.npy",
              std::string("\x93NUMPY\x01\x00", 8) + char(big.size()) + char(0) + big + "abcdef");
  expect_error<IoError>([&] { read_npy(tmp / "big.npy"); }, {"big.npy", "1000x1000x1000"});
  std::string wrong = "{'descr': '<i8', 'fortran_order': False, 'shape': (1, 1, 1), }\n";
  write_bytes(tmp / "i8.npy", std::string("\x93NUMPY\x01\x00", 8) + char(wrong.size()) + char(0) +
                                  wrong + std::string(8, '\0'));
  expect_error<IoError>([&] { read_npy(tmp / "i8.npy"); }, {"i8.npy", "<i8"});
}

TEST(Npz, StoredDeflatedZip64AndArraySelection) {
  TempDir tmp;
  const Volume a = random_volume({4, 6, 8}, DType::kUInt8, 1);
  const Volume b = random_volume({2, 3, 5}, DType::kBool, 2);
  write_npy(a, tmp / "a.npy");
  write_npy(b, tmp / "b.npy");
  const std::string a_bytes = read_bytes(tmp / "a.npy"), b_bytes = read_bytes(tmp / "b.npy");
  for (bool deflate : {false, true}) {
    for (bool zip64 : {false, true}) {
      write_bytes(tmp / "x.npz", make_zip({{"a.npy", a_bytes, deflate, zip64},
                                           {"b.npy", b_bytes, deflate, zip64}}));
      EXPECT_TRUE(same_voxels(a, read_npz(tmp / "x.npz", "a")));
      EXPECT_TRUE(same_voxels(b, read_npz(tmp / "x.npz", "b.npy")));
      expect_error<ConfigError>([&] { read_npz(tmp / "x.npz", ""); }, {"x.npz", "a, b", "--array"});
      expect_error<ConfigError>([&] { read_npz(tmp / "x.npz", "c"); }, {"x.npz", "'c'"});
    }
  }
  write_bytes(tmp / "end64.npz",
              make_zip({{"a.npy", a_bytes, true, true}, {"b.npy", b_bytes, false, false}},
                       /*zip64_end=*/true));
  EXPECT_TRUE(same_voxels(b, read_npz(tmp / "end64.npz", "b")));
  write_bytes(tmp / "one.npz", make_zip({{"im.npy", a_bytes, true, true}}));
  EXPECT_TRUE(same_voxels(a, read_npz(tmp / "one.npz", "")));
  EXPECT_EQ(list_npz_arrays(tmp / "one.npz"), std::vector<std::string>{"im"});
}

TEST(Npz, CorruptArchivesAreRefused) {
  TempDir tmp;
  const Volume a = random_volume({4, 6, 8}, DType::kUInt8, 1);
  write_npy(a, tmp / "a.npy");
  std::string zip = make_zip({{"a.npy", read_bytes(tmp / "a.npy"), false, false}});
  zip[200] ^= 0x55;  // a data byte: CRC mismatch
  write_bytes(tmp / "crc.npz", zip);
  expect_error<IoError>([&] { read_npz(tmp / "crc.npz", ""); }, {"crc.npz", "CRC"});
  std::string deflated = make_zip({{"a.npy", read_bytes(tmp / "a.npy"), true, false}});
  write_bytes(tmp / "cut.npz", deflated.substr(0, deflated.size() / 2));
  expect_error<IoError>([&] { read_npz(tmp / "cut.npz", ""); }, {"cut.npz"});
}

TEST(Hdf5, RoundTripWithSpacingAndSelection) {
  TempDir tmp;
  for (DType dtype : kAllTypes) {
    Volume v = random_volume({3, 4, 5}, dtype, 5);
    v.set_spacing({5, 2.5, 2.5, "nm"});
    write_hdf5(v, tmp / "v.h5", "/scan/volume");
    ReadReport report;
    const Volume back = read_hdf5(tmp / "v.h5", "", {}, &report);
    EXPECT_TRUE(same_voxels(v, back)) << dtype_name(dtype);
    EXPECT_EQ(back.spacing().str(), v.spacing().str());
    EXPECT_EQ(report.spacing_source, "metadata");
    EXPECT_TRUE(same_voxels(v, read_hdf5(tmp / "v.h5", "/scan/volume")));
  }
  expect_error<ConfigError>([&] { read_hdf5(tmp / "v.h5", "/nothing"); },
                            {"v.h5", "/nothing", "/scan/volume"});
}

// A 'unit' attribute holding several strings (found by scripts/fuzz.sh: it overflowed the
// one-string buffer it was read into) is not a unit: the loader warns and assumes um.
TEST(Hdf5, UnitAttributeWithSeveralStringsIsIgnoredWithAWarning) {
  TempDir tmp;
  for (const bool variable : {true, false}) {
    Volume v = random_volume({3, 4, 5}, DType::kUInt8, 5);
    v.set_spacing({5, 2.5, 2.5, "nm"});
    write_hdf5(v, tmp / "v.h5", "/v");
    {
      hid_t file = H5Fopen((tmp / "v.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      ASSERT_GE(file, 0);
      hid_t ds = H5Dopen2(file, "/v", H5P_DEFAULT);
      ASSERT_GE(H5Adelete(ds, "unit"), 0);
      const hsize_t n = 3;
      hid_t space = H5Screate_simple(1, &n, nullptr);
      hid_t type = H5Tcopy(H5T_C_S1);
      H5Tset_size(type, variable ? H5T_VARIABLE : 4);
      hid_t attr = H5Acreate2(ds, "unit", type, space, H5P_DEFAULT, H5P_DEFAULT);
      const char* texts[3] = {"nm", "um", "mm"};
      const char fixed[12] = {'n', 'm', 0, 0, 'u', 'm', 0, 0, 'm', 'm', 0, 0};
      ASSERT_GE(H5Awrite(attr, type, variable ? static_cast<const void*>(texts) : fixed), 0);
      H5Aclose(attr);
      H5Tclose(type);
      H5Sclose(space);
      H5Dclose(ds);
      H5Fclose(file);
    }
    ReadReport report;
    const Volume back = read_hdf5(tmp / "v.h5", "/v", {}, &report);
    EXPECT_TRUE(same_voxels(v, back));
    EXPECT_EQ(back.spacing().str(), "5 x 2.5 x 2.5 um") << (variable ? "variable" : "fixed");
    ASSERT_EQ(report.warnings.size(), 1u);
    EXPECT_NE(report.warnings[0].find("one string"), std::string::npos) << report.warnings[0];
  }
}

TEST(Hdf5, TruncatedAndForeignFilesAreRefused) {
  TempDir tmp;
  write_hdf5(random_volume({8, 16, 16}, DType::kUInt8), tmp / "v.h5", "/v");
  const std::string bytes = read_bytes(tmp / "v.h5");
  write_bytes(tmp / "cut.h5", bytes.substr(0, bytes.size() - 1000));
  expect_error<IoError>([&] { read_hdf5(tmp / "cut.h5", "/v"); }, {"cut.h5"});
  write_bytes(tmp / "text.h5", "hello");
  expect_error<IoError>([&] { read_hdf5(tmp / "text.h5", ""); }, {"text.h5"});
}

TEST(Load, DetectsFormatsAndAppliesSpacing) {
  TempDir tmp;
  const Volume v = random_volume({2, 3, 4}, DType::kUInt8);
  write_npy(v, tmp / "data.bin");  // an npy with a misleading extension
  EXPECT_EQ(detect_format(tmp / "data.bin"), Format::kNpy);
  LoadOptions o;
  o.spacing = Spacing{5, 2.5, 2.5, "nm"};
  ReadReport report;
  const Volume back = load_volume(tmp / "data.bin", o, &report);
  EXPECT_TRUE(same_voxels(v, back));
  EXPECT_EQ(back.spacing().str(), "5 x 2.5 x 2.5 nm");
  EXPECT_EQ(report.spacing_source, "command line");

  write_bytes(tmp / "junk.tif", "GIF89a...");
  expect_error<IoError>([&] { load_volume(tmp / "junk.tif"); }, {"junk.tif", "not a TIFF"});
  write_bytes(tmp / "junk.dat2", std::string(64, '\x07'));
  expect_error<IoError>([&] { load_volume(tmp / "junk.dat2"); }, {"junk.dat2", "not a recognised"});
  write_raw(v, tmp / "v.raw", "v.raw");
  expect_error<ConfigError>([&] { load_volume(tmp / "v.raw"); }, {"v.raw", "--shape"});
  o = {};
  o.shape = Shape{2, 3, 4};
  o.dtype = DType::kUInt8;
  EXPECT_TRUE(same_voxels(v, load_volume(tmp / "v.raw", o)));
  // --shape/--dtype on a file that describes itself is a mistake, not a request to reinterpret.
  write_tiff_file(v, tmp / "v.tif");
  expect_error<ConfigError>([&] { load_volume(tmp / "v.tif", o); }, {"v.tif", "TIFF", "--shape"});
}

TEST(StagedOutputs, DiscardedOutputsLeaveNothingBehind) {
  TempDir tmp;
  {
    StagedOutputs out = StagedOutputs::in_directory(tmp / "new");
    write_bytes(out.stage("a.txt"), "a");
    write_bytes(out.stage("sub/b.txt"), "b");
  }  // not committed
  EXPECT_TRUE(fs::is_empty(tmp.path()));
  fs::create_directory(tmp / "old");
  {
    StagedOutputs out = StagedOutputs::in_directory(tmp / "old");
    write_bytes(out.stage("sub/c.txt"), "c");
  }
  EXPECT_TRUE(fs::is_empty(tmp / "old"));
  {
    StagedOutputs out = StagedOutputs::in_directory(tmp / "old");
    write_bytes(out.stage("sub/c.txt"), "c");
    out.commit();
  }
  EXPECT_EQ(read_bytes(tmp / "old" / "sub" / "c.txt"), "c");
}

}  // namespace
}  // namespace mesorock::voxel::test
