// `rockflow lbm` through the built binary: the ladder's report, its refusals and messages.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "sim/solid_grid.h"
#include "support/test_support.h"

namespace {

namespace ms = mesorock::sim;
namespace mt = mesorock::test;

// Plates normal to z: pore layers k < h of a period H.
ms::SolidMask slit(std::int64_t h, std::int64_t H) {
  ms::SolidMask m;
  m.dims = {2, 2, H};
  m.solid.assign(static_cast<std::size_t>(4 * H), 0);
  for (std::int64_t k = h; k < H; ++k)
    for (std::int64_t j = 0; j < 2; ++j)
      for (std::int64_t i = 0; i < 2; ++i) m.solid[m.index(i, j, k)] = 1;
  return m;
}

mt::CommandResult lbm(const std::string& args, const mt::TempDir& dir) {
  return mt::run_command(mt::shell_quote(MESOROCK_ROCKFLOW) + " lbm " + args, dir.path());
}

TEST(LbmCommand, TheDefaultLadderGivesTheContinuumSlit) {
  mt::TempDir dir;
  ms::SolidMask m = slit(8, 10);
  m.voxel = {0.5, 0.5, 0.5};
  m.nm_per_rc = 20;
  const auto file = dir / "slit.h5";
  ms::write_solid_file(file, m, "test_lbm_command", "{}");
  const auto out = dir / "lbm";
  const auto r = lbm(mt::shell_quote(file.string()) + " --out " + mt::shell_quote(out.string()) +
                         " --backend cpu --threads 1 --tolerance 1e-10 --tau 0.8",
                     dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("extrapolated"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mD"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(mt::read_file(out / "lbm.json"));
  // The slit converges at second order to the continuum (h/H) h^2/12, in image voxels; the tiny
  // mask gets the four-rung ladder.
  const double continuum = 0.8 * 64 / 12;
  const auto& k = j["result"]["permeability"];
  EXPECT_EQ(j["options"]["refines"], nlohmann::json({1, 2, 3, 4}));
  ASSERT_EQ(j["rungs"].size(), 4u);
  EXPECT_NEAR(k["voxel2"].get<double>() / continuum - 1, 0, 1e-6);
  EXPECT_NEAR(k["rc2"].get<double>() / (0.25 * continuum) - 1, 0, 1e-6);
  EXPECT_NEAR(k["mD"].get<double>() / (0.25 * continuum * 400 / 986.9233) - 1, 0, 1e-6);
  EXPECT_NEAR(j["result"]["order"].get<double>(), 2, 0.01);
  EXPECT_TRUE(j["result"]["asymptotic"].get<bool>());
  EXPECT_TRUE(j["result"]["converged"].get<bool>());
  EXPECT_EQ(j["options"]["backend"], "cpu");
  for (const auto& g : j["rungs"]) {
    const int n = g["refine"].get<int>();
    EXPECT_NEAR(g["permeability"]["voxel2"].get<double>() / continuum - 1, 1.0 / (128 * n * n),
                1e-6);
    EXPECT_FALSE(g["history"].empty());
  }
  EXPECT_EQ(j["input_file"].get<std::string>(), file.string());
  EXPECT_TRUE(j.contains("mesorock_version"));

  // One lattice: its k, with a warning that it is not converged.
  const auto one = lbm(mt::shell_quote(file.string()) + " --out " + mt::shell_quote(out.string()) +
                           " --backend cpu --threads 1 --refine 2",
                       dir);
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_NE(one.err.find("not the converged value"), std::string::npos) << one.err;
  const auto j1 = nlohmann::json::parse(mt::read_file(out / "lbm.json"));
  EXPECT_FALSE(j1["result"]["extrapolated"].get<bool>());
  EXPECT_NEAR(j1["result"]["permeability"]["voxel2"].get<double>() / continuum - 1, 1.0 / 512,
              1e-5);
}

TEST(LbmCommand, RefusesWithOneLineNamingTheFile) {
  mt::TempDir dir;
  const auto out = dir / "lbm";
  const auto one_line = [](const mt::CommandResult& r) {
    return std::count(r.err.begin(), r.err.end(), '\n') == 1;
  };
  const std::string missing = (dir / "no_such_mask.h5").string();
  const auto bad = lbm(mt::shell_quote(missing) + " --out " + mt::shell_quote(out.string()), dir);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("no_such_mask.h5"), std::string::npos) << bad.err;
  EXPECT_TRUE(one_line(bad)) << bad.err;

  // A mask without solid: the flow accelerates without bound; it used to exit 0 with a k that
  // measured only --max-steps.
  ms::SolidMask open = slit(4, 4);
  const auto open_file = dir / "open.h5";
  ms::write_solid_file(open_file, open, "test_lbm_command", "{}");
  const auto o = lbm(mt::shell_quote(open_file.string()) + " --out " +
                         mt::shell_quote(out.string()) + " --backend cpu",
                     dir);
  EXPECT_EQ(o.exit_code, 2) << o.out;
  EXPECT_NE(o.err.find("open.h5"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("no solid voxel"), std::string::npos) << o.err;
  EXPECT_TRUE(one_line(o)) << o.err;
  EXPECT_FALSE(std::filesystem::exists(out / "lbm.json"));

  // A FIFO as the mask is refused at once, not read (which would block).
  const auto fifo = dir / "mask.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto f =
      lbm(mt::shell_quote(fifo.string()) + " --out " + mt::shell_quote(out.string()), dir);
  EXPECT_EQ(f.exit_code, 2);
  EXPECT_NE(f.err.find("not a regular file"), std::string::npos) << f.err;

  // An output folder that cannot be made is found before the work.
  ms::SolidMask m = slit(4, 6);
  const auto file = dir / "slit.h5";
  ms::write_solid_file(file, m, "test_lbm_command", "{}");
  {
    std::ofstream taken(dir / "taken");
    taken << "a file";
  }
  const auto w = lbm(mt::shell_quote(file.string()) + " --out " +
                         mt::shell_quote((dir / "taken").string()) + " --backend cpu",
                     dir);
  EXPECT_EQ(w.exit_code, 2);
  EXPECT_NE(w.err.find("taken"), std::string::npos) << w.err;
  EXPECT_EQ(w.err.find("lbm: refine"), std::string::npos) << "worked before checking: " << w.err;

  for (const char* args : {" --max-steps -5", " --threads -1", " --axis w", " --no-such-option",
                           " --tau 0.5", " --force 0", " --refine 3,2", " --refine 0",
                           " --refine 1.5", " --precision half", " --backend gpu"}) {
    const auto u =
        lbm(mt::shell_quote(file.string()) + " --out " + mt::shell_quote(out.string()) + args, dir);
    EXPECT_EQ(u.exit_code, 2) << args << ": " << u.err;
  }
}

}  // namespace
