// rockprep part 2 on the command line: analyze, crop, resample, walls. Good input gives the
// documented files with provenance; bad input gives exit code 2, one error line and no output.
#include <gtest/gtest.h>

#include <openvdb/io/File.h>
#include <nlohmann/json.hpp>

#include "test_util.h"
#include "voxel/load.h"
#include "voxel/phase_grids.h"
#include "voxel/pore_analysis.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/walls.h"

namespace mesorock::voxel::test {
namespace {

nlohmann::json read_json(const fs::path& path) {
  return nlohmann::json::parse(read_bytes(path));
}

void expect_provenance(const nlohmann::json& j, const std::string& command) {
  EXPECT_EQ(j["tool"], "rockprep");
  EXPECT_EQ(j["command"], command);
  EXPECT_TRUE(j.contains("mesorock_version"));
  EXPECT_TRUE(j.contains("git_commit"));
  EXPECT_TRUE(j["command_line"].is_array());
  EXPECT_TRUE(j["input"].contains("path"));
  EXPECT_TRUE(j.contains("parameters"));
}

// A small synthetic shale (labels with phase codes in truth.mhd) in tmp/syn.
void make_synth(const TempDir& tmp) {
  const CommandResult r = run_command("cd " + tmp.path().string() + " && " + rockprep() +
                                          " synth --shape 24,40,40 --blob 6 --seed 2 --quiet "
                                          "--out syn",
                                      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

TEST(CliPart2, HelpListsTheCommands) {
  TempDir tmp;
  const CommandResult r = run_command(rockprep() + " --help", tmp.path());
  EXPECT_EQ(r.exit_code, 0);
  for (const char* sub : {"analyze", "crop", "resample", "walls"}) {
    EXPECT_NE(r.out.find(sub), std::string::npos) << sub;
  }
  const CommandResult w = run_command(rockprep() + " walls --help", tmp.path());
  EXPECT_EQ(w.exit_code, 0);
  EXPECT_NE(w.out.find("--max-particles"), std::string::npos);
  EXPECT_NE(w.out.find("--nm-per-rc"), std::string::npos);
}

TEST(CliPart2, AnalyzeWritesReportAndPlots) {
  TempDir tmp;
  make_synth(tmp);
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult r = run_command(cd + " analyze syn/truth.mhd --largest 3 --out an", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  for (const char* stage : {"porosity, interfaces", "clusters, 6-connected",
                            "clusters, 26-connected", "local thickness", "write an"}) {
    EXPECT_NE(r.out.find(stage), std::string::npos) << stage << "\n" << r.out;
  }
  for (const char* f : {"analysis.json", "pore_size_distribution.png", "porosity_profile.png"}) {
    ASSERT_TRUE(fs::exists(tmp / "an" / f)) << f;
  }
  EXPECT_EQ(read_bytes(tmp / "an" / "porosity_profile.png").substr(1, 3), "PNG");
  const auto j = read_json(tmp / "an" / "analysis.json");
  expect_provenance(j, "analyze");
  EXPECT_EQ(j["input"]["phase_codes"], "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore");
  EXPECT_EQ(j["unit"], "nm");
  // The numbers agree with the library on the same labels.
  const Volume labels = load_volume(tmp / "syn" / "truth.mhd");
  const PoreStatistics stats = measure_pores(labels);
  EXPECT_DOUBLE_EQ(j["porosity"].get<double>(), stats.counts.porosity());
  EXPECT_DOUBLE_EQ(j["surface"]["specific_surface_area"].get<double>(),
                   stats.specific_surface_area(labels.spacing()));
  EXPECT_EQ(j["surface"]["specific_surface_area_unit"], "1/nm");
  const PoreRuns runs = find_pore_runs(labels);
  for (int c : {6, 26}) {
    ClusterOptions o;
    o.connectivity = c;
    const PercolationSummary sum = summarize_clusters(find_pore_clusters(runs, o), 3);
    const auto& jc = j["clusters"][std::to_string(c)];
    EXPECT_EQ(jc["count"].get<std::int64_t>(), sum.clusters);
    EXPECT_DOUBLE_EQ(jc["percolating_porosity"]["x"].get<double>(),
                     double(sum.spanning_voxels[2]) / double(stats.counts.counted()));
    EXPECT_EQ(jc["largest_isolated"].size(), std::min<std::size_t>(3, sum.largest_isolated.size()));
  }
  EXPECT_EQ(j["profiles"]["z"]["porosity"].size(), 24u);
  EXPECT_DOUBLE_EQ(j["profiles"]["z"]["position"][0].get<double>(), 2.5);  // slice centre, nm
  const auto& lt = j["local_thickness"];
  double sum = 0;
  for (const auto& f : lt["pore_volume_fraction"]) sum += f.get<double>();
  EXPECT_NEAR(sum, 1.0, 1e-9);
  EXPECT_GT(lt["max"].get<double>(), lt["mean"].get<double>());
  // A segment output folder is accepted as input (its labels.mhd), --no-thickness skips the
  // distribution and its plot.
  r = run_command(cd + " segment syn/truth.mhd --labels 1=pore,2=organic,3=inorganic,"
                       "4=organic_pore --quiet --out seg",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_command(cd + " analyze seg --no-thickness --connectivity 26 --out an2", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j2 = read_json(tmp / "an2" / "analysis.json");
  EXPECT_TRUE(j2["local_thickness"].is_null());
  EXPECT_FALSE(fs::exists(tmp / "an2" / "pore_size_distribution.png"));
  EXPECT_FALSE(j2["clusters"].contains("6"));
  EXPECT_EQ(j2["clusters"]["26"]["count"], j["clusters"]["26"]["count"]);
}

TEST(CliPart2, CropAndResampleCarryLabelsAndOrigin) {
  TempDir tmp;
  make_synth(tmp);
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult r =
      run_command(cd + " crop syn/truth.mhd --box 4:20,10:30,0:40 --out c.mhd", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Volume full = load_volume(tmp / "syn" / "truth.mhd");
  const Volume c = load_volume(tmp / "c.mhd");
  ASSERT_EQ(c.shape(), (Shape{16, 20, 40}));
  EXPECT_EQ(c.spacing().str(), "5 x 2.5 x 2.5 nm");
  EXPECT_EQ(c.data<std::uint8_t>()[0], full.data<std::uint8_t>()[(4 * 40 + 10) * 40]);
  auto side = read_json(tmp / "c.json");
  expect_provenance(side, "crop");
  EXPECT_EQ(side["origin_zyx"], (std::vector<double>{20, 25, 0}));  // nm
  EXPECT_TRUE(side.contains("phase_codes"));
  // The same region by physical box (voxel centres inside), then a crop of the crop: the
  // origins add up.
  r = run_command(cd + " crop syn/truth.mhd --physical-box 20:100,25:75,0:100 --out p.mhd",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(same_voxels(load_volume(tmp / "p.mhd"), c));
  r = run_command(cd + " crop c.mhd --box 1:2,0:20,0:40 --out cc.mhd", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_json(tmp / "cc.json")["origin_zyx"], (std::vector<double>{25, 25, 0}));
  // The cropped labels analyse without a label map.
  r = run_command(cd + " analyze c.mhd --no-thickness --quiet --out an", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Resample: nearest for labels; twice as coarse in-plane gives an isotropic 5 nm grid.
  r = run_command(cd + " resample c.mhd --target-spacing 5 --out r.mhd", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Volume res = load_volume(tmp / "r.mhd");
  EXPECT_EQ(res.shape(), (Shape{16, 10, 20}));
  EXPECT_EQ(res.spacing().str(), "5 x 5 x 5 nm");
  const auto rs = read_json(tmp / "r.json");
  expect_provenance(rs, "resample");
  EXPECT_EQ(rs["parameters"]["interpolation"], "nearest");
  EXPECT_EQ(rs["input"]["provenance"]["command"], "crop");  // the chain is recorded
  r = run_command(cd + " analyze r.mhd --quiet --out an_r", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

TEST(CliPart2, WallsWriteMasksCountsAndEstimate) {
  TempDir tmp;
  make_synth(tmp);
  const std::string cd = "cd " + tmp.path().string() + " && " + rockprep();
  CommandResult r = run_command(cd + " walls syn/truth.mhd --nm-per-rc 5 --out w", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("estimate:"), std::string::npos) << r.out;
  const auto j = read_json(tmp / "w" / "walls.json");
  expect_provenance(j, "walls");
  EXPECT_EQ(j["wall_layers_zyx"], (std::vector<int>{1, 2, 2}));  // 5 nm slices, 2.5 nm pixels
  EXPECT_EQ(j["voxel_size_rc_zyx"], (std::vector<double>{1, 0.5, 0.5}));
  // Counts agree with the brute-force definition, computed here on the labels.
  const Volume labels = load_volume(tmp / "syn" / "truth.mhd");
  const Shape s = labels.shape();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  std::array<std::int64_t, 5> expected{};
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::uint8_t c = p[(z * s.ny + y) * s.nx + x];
        if (c != 2 && c != 3) continue;
        bool near = false;
        for (std::int64_t a = std::max<std::int64_t>(0, z - 1); a <= std::min(s.nz - 1, z + 1); ++a)
          for (std::int64_t b = std::max<std::int64_t>(0, y - 2); b <= std::min(s.ny - 1, y + 2);
               ++b)
            for (std::int64_t d = std::max<std::int64_t>(0, x - 2); d <= std::min(s.nx - 1, x + 2);
                 ++d) {
              const std::uint8_t n = p[(a * s.ny + b) * s.nx + d];
              near = near || n == 1 || n == 4;
            }
        expected[c] += near;
      }
  EXPECT_EQ(j["walls"]["organic"]["voxels"].get<std::int64_t>(), expected[2]);
  EXPECT_EQ(j["walls"]["inorganic"]["voxels"].get<std::int64_t>(), expected[3]);
  const double v_rc = 1 * 0.5 * 0.5;
  const double pore = double(j["pore_voxels"].get<std::int64_t>());
  EXPECT_DOUBLE_EQ(j["particles"]["fluid_particles"].get<double>(), std::ceil(6.88 * pore * v_rc));
  EXPECT_DOUBLE_EQ(j["particles"]["wall_particles"].get<double>(),
                   std::ceil(6.88 * double(expected[2] + expected[3]) * v_rc));
  EXPECT_DOUBLE_EQ(j["particles"]["gpu_bytes"].get<double>(),
                   250 * j["particles"]["total_particles"].get<double>());
  EXPECT_EQ(j["estimate_before_sweep"]["wall_volume"], "estimated from faces");
  // The grids: one mask per solid phase, voxel counts as in the JSON.
  initialize_openvdb();
  openvdb::io::File file((tmp / "w" / "walls.vdb").string());
  file.open();
  for (const char* phase : {"organic", "inorganic"}) {
    auto g = file.readGrid(phase);
    ASSERT_TRUE(g) << phase;
    EXPECT_EQ(std::int64_t(g->activeVoxelCount()), j["walls"][phase]["voxels"].get<std::int64_t>());
    EXPECT_EQ(g->metaValue<std::string>("wall_layers_zyx"), "1,2,2");
  }
  EXPECT_TRUE(file.getMetadata()->metaValue<std::string>("provenance").find("walls") !=
              std::string::npos);
  file.close();
  // Scale-free: rc per voxel; a thicker wall holds more voxels.
  r = run_command(cd + " walls syn/truth.mhd --rc-per-voxel 0.5 --thickness-rc 2 --quiet --out w2",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j2 = read_json(tmp / "w2" / "walls.json");
  EXPECT_EQ(j2["wall_layers_zyx"], (std::vector<int>{2, 4, 4}));
  EXPECT_GT(j2["wall_voxels"].get<std::int64_t>(), j["wall_voxels"].get<std::int64_t>());
}

TEST(CliPart2, BadInputsExitTwoWithOneLineAndNoOutput) {
  TempDir tmp;
  make_synth(tmp);
  // An unlabelled volume (grey values, no phase codes).
  Volume grey(Shape{4, 5, 6}, DType::kUInt8);
  for (std::int64_t i = 0; i < grey.voxels(); ++i) grey.data<std::uint8_t>()[i] = i % 3 ? 255 : 0;
  write_raw(grey, tmp / "rock.raw", "rock.raw");
  // Unknown option values.
  expect_bad_input(tmp, "analyze syn/truth.mhd --connectivity 18 --out a", "connectivity");
  expect_bad_input(tmp, "analyze syn/truth.mhd --profile-axis w --out a", "profile-axis");
  expect_bad_input(tmp, "resample syn/truth.mhd --zoom 2 --interpolation cubic --out r.mhd",
                   "interpolation");
  // Labels are never guessed: an unlabelled volume needs --labels; a map must cover it.
  expect_bad_input(tmp, "analyze rock.raw --shape 4,5,6 --dtype uint8 --out a", "rock.raw");
  expect_bad_input(tmp, "analyze rock.raw --shape 4,5,6 --dtype uint8 --labels 0=pore --out a",
                   "rock.raw");
  // Crop boxes outside the volume (24x40x40), empty, or both kinds given.
  expect_bad_input(tmp, "crop syn/truth.mhd --box 0:25,0:40,0:40 --out c.mhd", "syn/truth.mhd");
  expect_bad_input(tmp, "crop syn/truth.mhd --box 30:35,0:40,0:40 --out c.mhd", "outside");
  expect_bad_input(tmp, "crop syn/truth.mhd --box 5:5,0:40,0:40 --out c.mhd", "empty");
  expect_bad_input(tmp, "crop syn/truth.mhd --physical-box 0:500,0:10,0:10 --out c.mhd",
                   "syn/truth.mhd");
  expect_bad_input(tmp, "crop syn/truth.mhd --out c.mhd", "--box");
  expect_bad_input(tmp, "crop syn/truth.mhd --box 0:1,0:1 --out c.mhd", "--box");
  // Resample: linear on labels, a zero factor.
  expect_bad_input(tmp, "resample syn/truth.mhd --zoom 2 --interpolation linear --out r.mhd",
                   "syn/truth.mhd");
  expect_bad_input(tmp, "resample syn/truth.mhd --zoom 0 --out r.mhd", "zoom");
  // Walls: missing scale, both scales, no physical unit, a wall thinner than the cutoff, and a
  // particle estimate over the limit.
  expect_bad_input(tmp, "walls syn/truth.mhd --out w", "--nm-per-rc");
  expect_bad_input(tmp, "walls syn/truth.mhd --nm-per-rc 5 --rc-per-voxel 1 --out w",
                   "--rc-per-voxel");
  expect_bad_input(tmp,
                   "walls rock.raw --shape 4,5,6 --dtype uint8 --labels 0=pore,255=solid "
                   "--nm-per-rc 5 --out w",
                   "rock.raw");
  expect_bad_input(tmp, "walls syn/truth.mhd --nm-per-rc 5 --thickness-rc 0.5 --out w",
                   "below the mDPD cutoff");
  const CommandResult r =
      run_command("cd " + tmp.path().string() + " && " + rockprep() +
                      " walls syn/truth.mhd --nm-per-rc 5 --max-particles 1000 --out w",
                  tmp.path());
  EXPECT_EQ(r.exit_code, 2);
  ASSERT_EQ(lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find("syn/truth.mhd: the particle estimate"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("exceeds the limit of 1000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("GiB of GPU memory"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--max-particles"), std::string::npos) << r.err;
  // Raising the limit lets the same command through.
  const CommandResult ok =
      run_command("cd " + tmp.path().string() + " && " + rockprep() +
                      " walls syn/truth.mhd --nm-per-rc 5 --max-particles 100000000 --quiet "
                      "--out w_ok",
                  tmp.path());
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  fs::remove_all(tmp / "w_ok");
  // Nothing was written.
  expect_only(tmp.path(), {"syn", "rock.raw"});
}

}  // namespace
}  // namespace mesorock::voxel::test
