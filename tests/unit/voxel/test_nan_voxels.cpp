// NaN and infinite voxels of a float image are no data (voxel/volume.h NonFiniteCounts): load
// counts them, says so and records the count; segment labels them outside and says so. They used
// to pass silently. Also: a negative voxel spacing is named by where it came from.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "test_util.h"
#include "voxel/load.h"
#include "voxel/tiff_io.h"

namespace mesorock::voxel::test {
namespace {

// 8 x 8 x 8 float voxels: grey 10 (pore-dark) in the lower half, 200 in the upper, with 3 NaN,
// one +inf and one -inf in the upper half.
Volume grey_with_holes() {
  Volume v(Shape{8, 8, 8}, DType::kFloat32);
  float* d = v.data<float>();
  for (std::int64_t i = 0; i < v.voxels(); ++i) d[i] = i < 256 ? 10.0f : 200.0f;
  d[300] = d[301] = d[450] = std::numeric_limits<float>::quiet_NaN();
  d[400] = std::numeric_limits<float>::infinity();
  d[401] = -std::numeric_limits<float>::infinity();
  return v;
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(NanVoxels, CountedByKind) {
  const NonFiniteCounts c = count_non_finite(grey_with_holes());
  EXPECT_EQ(c.nan, 3);
  EXPECT_EQ(c.pos_inf, 1);
  EXPECT_EQ(c.neg_inf, 1);
  EXPECT_EQ(c.total(), 5);
  EXPECT_EQ(count_non_finite(Volume(Shape{2, 2, 2}, DType::kUInt8)).total(), 0);
  const std::string note = non_finite_note(c, 512);
  EXPECT_NE(note.find("5 of 512 voxels"), std::string::npos) << note;
  EXPECT_NE(note.find("outside"), std::string::npos) << note;
}

TEST(NanVoxels, LoadSaysHowManyAndRecordsThem) {
  TempDir tmp;
  write_tiff_file(grey_with_holes(), tmp / "grey.tif");
  const CommandResult r = run_command(
      "cd " + tmp.path().string() + " && " + rockprep() + " load grey.tif --out grey.mhd",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("5 of 512 voxels"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("3 NaN"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("segment labels them outside"), std::string::npos) << r.err;
  const nlohmann::json j = read_json(tmp / "grey.json");
  ASSERT_TRUE(j["input"].contains("non_finite_voxels")) << j.dump(2);
  EXPECT_EQ(j["input"]["non_finite_voxels"]["nan"], 3);
  EXPECT_EQ(j["input"]["non_finite_voxels"]["+inf"], 1);
  EXPECT_EQ(j["input"]["non_finite_voxels"]["-inf"], 1);
  // The copy keeps them (it is a copy), and reading it back reports them again.
  EXPECT_EQ(count_non_finite(load_volume(tmp / "grey.mhd")).total(), 5);
}

TEST(NanVoxels, SegmentLabelsThemOutsideAndSaysSo) {
  TempDir tmp;
  write_tiff_file(grey_with_holes(), tmp / "grey.tif");
  const CommandResult r =
      run_command("cd " + tmp.path().string() + " && " + rockprep() +
                      " segment grey.tif --thresholds 100 --phases pore,solid --out seg",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("segment labels them outside"), std::string::npos) << r.err;
  const nlohmann::json j = read_json(tmp / "seg" / "segment.json");
  EXPECT_EQ(j["outside_voxels"], 5) << j.dump(2);
  EXPECT_EQ(j["parameters"]["non_finite_voxels_labelled_outside"], 5) << j.dump(2);
  EXPECT_EQ(j["input"]["non_finite_voxels"]["nan"], 3) << j.dump(2);
  EXPECT_DOUBLE_EQ(j["porosity"].get<double>(), 256.0 / 507.0);
  // A Gaussian spreads each NaN over its neighbours: segment counts them again after filtering.
  const CommandResult g =
      run_command("cd " + tmp.path().string() + " && " + rockprep() +
                      " segment grey.tif --gaussian 1 --thresholds 100 --phases pore,solid "
                      "--out seg_g",
                  tmp.path());
  ASSERT_EQ(g.exit_code, 0) << g.err;
  EXPECT_NE(g.err.find("after the filters"), std::string::npos) << g.err;
  const nlohmann::json k = read_json(tmp / "seg_g" / "segment.json");
  EXPECT_EQ(k["parameters"]["non_finite_voxels_labelled_outside"], k["outside_voxels"])
      << k.dump(2);
  EXPECT_GT(k["outside_voxels"].get<int>(), 5) << k.dump(2);
}

// A negative spacing said "voxel spacing must be positive and finite", naming no file or option.
TEST(NegativeSpacing, IsNamedByItsSource) {
  TempDir tmp;
  Volume v(Shape{2, 2, 2}, DType::kUInt8);
  std::fill(v.data<std::uint8_t>(), v.data<std::uint8_t>() + 8, std::uint8_t(1));
  write_bytes(tmp / "neg.raw", std::string(8, '\1'));
  write_bytes(tmp / "neg.mhd",
              "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementSpacing = -1 1 1\n"
              "ElementType = MET_UCHAR\nElementDataFile = neg.raw\n");
  expect_bad_input(tmp, "load neg.mhd --out out.mhd", "neg.mhd: ElementSpacing");
  write_tiff_file(v, tmp / "ok.tif");
  expect_bad_input(tmp, "load ok.tif --spacing=-1,1,1 --unit nm --out out.mhd", "--spacing");
}

}  // namespace
}  // namespace mesorock::voxel::test
