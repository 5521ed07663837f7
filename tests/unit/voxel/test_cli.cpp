// The rockprep command line: bad input gives exit code 2, one error line naming the file, and no
// output at all; good input gives the documented files.
#include <gtest/gtest.h>

#include <openvdb/io/File.h>
#include <nlohmann/json.hpp>

#include "test_util.h"
#include "voxel/load.h"
#include "voxel/phase_grids.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/tiff_io.h"

namespace mesorock::voxel::test {
namespace {

void write_stack(const fs::path& dir, const Volume& v) {
  StagedOutputs out = StagedOutputs::in_directory(dir);
  write_tiff_slices(v, out, "", {});
  out.commit();
}

TEST(Cli, HelpVersionAndUsageErrors) {
  TempDir tmp;
  CommandResult r = run_command(rockprep() + " --version", tmp.path());
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("rockprep 0."), std::string::npos);
  r = run_command(rockprep() + " --help", tmp.path());
  EXPECT_EQ(r.exit_code, 0);
  for (const char* sub : {"load", "filter", "segment", "synth"}) {
    EXPECT_NE(r.out.find(sub), std::string::npos) << sub;
  }
  r = run_command(rockprep() + " segment --help", tmp.path());
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--otsu"), std::string::npos);
  r = run_command(rockprep() + " segment x --no-such-option --out y", tmp.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
  expect_only(tmp.path(), {});
}

TEST(Cli, BadInputsExitTwoWithOneLineAndNoOutput) {
  TempDir tmp;
  auto one = [](std::uint32_t, std::uint32_t) { return 1u; };
  // Slices of different sizes, and of different types.
  fs::create_directory(tmp / "sizes");
  write_plain_tiff(tmp / "sizes" / "slice_000.tif", 16, 16, 16, one);
  write_plain_tiff(tmp / "sizes" / "slice_007.tif", 16, 15, 16, one);
  expect_bad_input(tmp, "load sizes --out out.mhd", "sizes/slice_007.tif");
  fs::create_directory(tmp / "types");
  write_plain_tiff(tmp / "types" / "s1.tif", 16, 16, 16, one);
  write_plain_tiff(tmp / "types" / "s2.tif", 16, 16, 8, one);
  expect_bad_input(tmp, "segment types --otsu 2 --out seg", "types/s2.tif");
  // A truncated slice (libtiff puts its directory after the data, so it is lost).
  fs::create_directory(tmp / "cut");
  write_plain_tiff(tmp / "cut" / "s1.tif", 64, 64, 8, one);
  write_plain_tiff(tmp / "cut" / "s2.tif", 64, 64, 8, one);
  const std::string whole = read_bytes(tmp / "cut" / "s2.tif");
  write_bytes(tmp / "cut" / "s2.tif", whole.substr(0, whole.size() - 200));
  expect_bad_input(tmp, "segment cut --otsu 2 --out seg", "cut/s2.tif");
  // Garbage bytes with a TIFF name; an empty folder.
  write_bytes(tmp / "junk.tif", "\x89PNG\r\n\x1a\n not a tiff");
  expect_bad_input(tmp, "load junk.tif --out out.mhd", "junk.tif");
  fs::create_directory(tmp / "empty");
  expect_bad_input(tmp, "segment empty --otsu 3 --out seg", "empty");
  // A raw file whose size disagrees with its header, and with --shape.
  write_bytes(tmp / "v.raw", std::string(999, '\0'));
  write_bytes(tmp / "v.mhd",
              "NDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\nElementDataFile = v.raw\n");
  expect_bad_input(tmp, "segment v.mhd --otsu 2 --out seg", "v.raw");
  expect_bad_input(tmp, "load v.raw --shape 10,10,10 --dtype uint8 --out out.mhd", "v.raw");
  // An absurd header size.
  write_bytes(tmp / "huge.mhd",
              "NDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_FLOAT\n"
              "ElementDataFile = v.raw\n");
  expect_bad_input(tmp, "load huge.mhd --out out.mhd", "huge.mhd");
  // A label map that leaves voxels unassigned.
  Volume labels(Shape{2, 3, 4}, DType::kUInt8);
  for (std::int64_t i = 0; i < labels.voxels(); ++i)
    labels.data<std::uint8_t>()[i] = i % 3 ? 255 : 0;
  write_raw(labels, tmp / "l.raw", "l.raw");
  expect_bad_input(tmp, "segment l.raw --shape 2,3,4 --dtype uint8 --labels 0=pore --out seg",
                   "l.raw");
  // Nothing was written: only the inputs made above are there.
  expect_only(tmp.path(), {"sizes", "types", "cut", "junk.tif", "empty", "v.raw", "v.mhd",
                           "huge.mhd", "l.raw"});
}

TEST(Cli, SynthFilterSegmentPipeline) {
  TempDir tmp;
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult r = run_command(
      cd + " synth --shape 32,48,48 --blob 8 --noise 15 --seed 4 --out syn", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(tmp / "syn" / "grey" / "slice_0031.tif"));
  EXPECT_TRUE(fs::exists(tmp / "syn" / "truth.mhd"));
  const auto synth = nlohmann::json::parse(read_bytes(tmp / "syn" / "synth.json"));
  EXPECT_EQ(synth["parameters"]["seed"], 4);
  // Running synth again into the same folder is refused rather than mixing slices.
  r = run_command(cd + " synth --shape 8,8,8 --out syn", tmp.path());
  EXPECT_EQ(r.exit_code, 2);

  r = run_command(cd + " filter syn/grey --median 0.75,1.5,1.5 --median-shape ball --out f.mhd",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("median filter"), std::string::npos) << r.out;
  const auto filtered = nlohmann::json::parse(read_bytes(tmp / "f.json"));
  EXPECT_EQ(filtered["filters"]["median_window_voxels"], 9);
  EXPECT_EQ(filtered["input"]["unit"], "nm");

  r = run_command(cd + " segment f.mhd --otsu 3 --organic-pores --truth syn/truth.mhd --out seg",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;  // no warnings for a plausible porosity
  for (const char* f :
       {"phases.vdb", "labels.vdb", "labels.mhd", "labels.raw", "labels.json", "segment.json"}) {
    EXPECT_TRUE(fs::exists(tmp / "seg" / f)) << f;
  }
  const auto seg = nlohmann::json::parse(read_bytes(tmp / "seg" / "segment.json"));
  EXPECT_EQ(seg["parameters"]["method"], "multi-otsu");
  EXPECT_EQ(seg["parameters"]["thresholds"].size(), 2u);
  EXPECT_EQ(seg["input"]["provenance"]["command"], "filter");  // the chain is recorded
  EXPECT_EQ(seg["unit"], "nm");
  EXPECT_EQ(seg["spacing_zyx"][0], 5.0);
  EXPECT_GT(seg["truth"]["agreement"].get<double>(), 0.9);
  const double porosity = seg["porosity"];
  EXPECT_NEAR(porosity, synth["truth_porosity"].get<double>(), 0.03);
  double sum = 0;
  for (const auto& [name, phase] : seg["phases"].items()) sum += phase["fraction"].get<double>();
  EXPECT_NEAR(sum, 1.0, 1e-12);
  // The labels file loads back with the spacing and matches the statistics.
  const Volume labels = load_volume(tmp / "seg" / "labels.mhd");
  EXPECT_EQ(labels.spacing().str(), "5 x 2.5 x 2.5 nm");
  EXPECT_NEAR(count_phases(labels).porosity(), porosity, 1e-12);
  for (const auto& e : fs::directory_iterator(tmp.path())) {
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos);
  }
}

TEST(Cli, LabelledRockAndInvertedMapWarning) {
  TempDir tmp;
  Volume v(Shape{4, 5, 6}, DType::kUInt8);
  for (std::int64_t i = 0; i < v.voxels(); ++i) v.data<std::uint8_t>()[i] = i % 5 == 0 ? 0 : 255;
  write_raw(v, tmp / "rock.raw", "rock.raw");
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult r = run_command(cd + " segment rock.raw --shape 4,5,6 --dtype uint8 --spacing "
                                     "1,1,1 --unit um --labels 0=pore,255=solid --out ok",
                                tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty());
  EXPECT_NEAR(
      nlohmann::json::parse(read_bytes(tmp / "ok" / "segment.json"))["porosity"].get<double>(), 0.2,
      1e-12);
  r = run_command(cd + " segment rock.raw --shape 4,5,6 --dtype uint8 --labels 255=pore,0=solid "
                       "--out inverted",
                  tmp.path());
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.err.find("warning"), std::string::npos);
  EXPECT_NE(r.err.find("implausible"), std::string::npos);
  const auto j = nlohmann::json::parse(read_bytes(tmp / "inverted" / "segment.json"));
  EXPECT_EQ(j["warnings"].size(), 1u);
  // The phase grids: masks and the label grid by default, masks only on request.
  auto grid_names = [](const fs::path& vdb) {
    initialize_openvdb();
    openvdb::io::File file(vdb.string());
    file.open();
    std::vector<std::string> names;
    for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(*it);
    file.close();
    std::sort(names.begin(), names.end());
    return names;
  };
  EXPECT_EQ(grid_names(tmp / "ok" / "phases.vdb"), (std::vector<std::string>{"inorganic", "pore"}));
  EXPECT_EQ(grid_names(tmp / "ok" / "labels.vdb"), (std::vector<std::string>{"labels"}));
  EXPECT_EQ(
      nlohmann::json::parse(read_bytes(tmp / "ok" / "segment.json"))["parameters"]["label_grid"],
      "uint8");
  r = run_command(cd + " segment rock.raw --shape 4,5,6 --dtype uint8 --labels 0=pore,255=solid "
                       "--no-label-grid --out masks",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(grid_names(tmp / "masks" / "phases.vdb"),
            (std::vector<std::string>{"inorganic", "pore"}));
  EXPECT_FALSE(fs::exists(tmp / "masks" / "labels.vdb"));
  // --label-grid int32 writes the standard OpenVDB type.
  r = run_command(cd + " segment rock.raw --shape 4,5,6 --dtype uint8 --labels 0=pore,255=solid "
                       "--label-grid int32 --out wide",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  {
    openvdb::io::File file((tmp / "wide" / "labels.vdb").string());
    file.open();
    EXPECT_EQ(file.readGrid("labels")->type(), "Tree_int32_5_4_3");
    file.close();
  }
  // Load converts to the canonical volume with the command-line spacing recorded.
  r = run_command(cd + " load rock.raw --shape 4,5,6 --dtype uint8 --spacing 5,2.5,2.5 --unit "
                       "nm --out canon.mhd",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Volume back = load_volume(tmp / "canon.mhd");
  EXPECT_TRUE(same_voxels(v, back));
  EXPECT_EQ(back.spacing().str(), "5 x 2.5 x 2.5 nm");
}

TEST(Cli, FieldOfViewFoundByFilterIsExcludedBySegment) {
  // A scanner-like slice stack: a disk of rock (two grey levels, half each) and the value 1
  // outside it.
  TempDir tmp;
  const double cx = 30.5, cy = 27.0, r = 22.0;
  Volume v(Shape{3, 56, 64}, DType::kUInt16);
  std::int64_t outside = 0;
  for (std::int64_t z = 0; z < 3; ++z)
    for (std::int64_t y = 0; y < 56; ++y)
      for (std::int64_t x = 0; x < 64; ++x) {
        const bool in = (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
        outside += !in;
        v.data<std::uint16_t>()[(z * 56 + y) * 64 + x] = !in ? 1 : (x < cx ? 500 : 1000);
      }
  write_raw(v, tmp / "disk.raw", "disk.raw");
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult res = run_command(
      cd + " filter disk.raw --shape 3,56,64 --dtype uint16 --fov value=1 --out f.mhd", tmp.path());
  ASSERT_EQ(res.exit_code, 0) << res.err;
  const auto f = nlohmann::json::parse(read_bytes(tmp / "f.json"));
  EXPECT_NEAR(f["filters"]["field_of_view"]["cx"].get<double>(), cx, 0.1);
  EXPECT_NEAR(f["filters"]["field_of_view"]["radius"].get<double>(), r, 0.2);
  res = run_command(cd + " segment f.mhd --thresholds 750 --out s", tmp.path());
  ASSERT_EQ(res.exit_code, 0) << res.err;
  const auto seg = nlohmann::json::parse(read_bytes(tmp / "s" / "segment.json"));
  // The fitted circle differs from the drawn one by a few boundary voxels at most.
  EXPECT_NEAR(seg["outside_voxels"].get<double>(), double(outside), 0.01 * double(outside));
  EXPECT_NEAR(seg["porosity"].get<double>(), 0.5, 0.03);
  EXPECT_EQ(seg["parameters"]["field_of_view_from"], "input sidecar");
}

}  // namespace
}  // namespace mesorock::voxel::test
