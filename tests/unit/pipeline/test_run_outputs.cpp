// `rockflow run` outputs: every XDMF file opens (each dataset it names exists in HDF5 with the
// stated shape and type), profiles and fields hold what the particles say, summary.json carries
// averages with error bars and the unit system.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/test_support.h"
#include "support/xdmf_check.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::TempDir;

namespace {

// A small reverse-Poiseuille box: body force +g x below z = 3, -g above.
const char* kScene = R"(name = "outputs"
seed = 9
[box]
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 6.0]
[model]
conservative = "mdpd"
body_force_profile = "reversed"
body_force_axis = "z"
[[types]]
name = "water"
body_force = [0.2, 0.0, 0.0]
[[pairs]]
types = ["water", "water"]
A = -40.0
B = 25.0
gamma = 4.5
[[init]]
kind = "random"
type = "water"
density = 7.0
[[run]]
name = "relax"
steps = 100
dt = 0.005
[[run]]
name = "flow"
steps = 400
dt = 0.01
[output]
thermo_every = 20
snapshot_every = 250
[[output.profiles]]
axis = "z"
bins = 6
every = 5
[output.fields]
cells = [2, 2, 3]
every = 20
[units]
nm_per_rc = 0.852
)";

struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (size_t k = 0; k < header.size(); ++k)
      if (header[k] == name) return static_cast<int>(k);
    return -1;
  }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) out.push_back(cell);
  return out;
}

CsvTable read_csv(const fs::path& p) {
  CsvTable t;
  std::stringstream in(mesorock::test::read_file(p));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (t.header.empty()) {
      t.header = split(line);
      continue;
    }
    std::vector<double> row;
    for (const auto& c : split(line)) row.push_back(std::strtod(c.c_str(), nullptr));
    t.rows.push_back(row);
  }
  return t;
}

}  // namespace

TEST(RunOutputs, EveryFileOpensAndHoldsTheAveragedObservables) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  {
    std::ofstream f(scene);
    f << kScene;
  }
  const CommandResult r = mesorock::test::run_command(
      mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
          mesorock::test::shell_quote(scene.string()) + " --out " +
          mesorock::test::shell_quote((dir / "out").string()) + " --threads 2",
      dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path out = dir / "out";
  for (const char* f :
       {"final.xmf", "profile_z.xmf", "fields.xmf", "snapshots/step_000000250.xmf"}) {
    ASSERT_TRUE(fs::exists(out / f)) << f;
    const auto problems = mesorock::test::xdmf_problems(out / f);
    EXPECT_TRUE(problems.empty()) << f << ": " << (problems.empty() ? "" : problems.front());
  }
  // Snapshots every 250 steps of the whole run (relax ends at step 100): 250 and 500.
  EXPECT_TRUE(fs::exists(out / "snapshots/step_000000500.h5"));
  EXPECT_FALSE(fs::exists(out / "snapshots/step_000000100.h5"));

  // Profile: 6 bins along z, density sums to N / V on average, flow reverses at the mid-plane.
  const CsvTable p = read_csv(out / "profile_z.csv");
  ASSERT_EQ(p.rows.size(), 6u);
  const int rho = p.column("density"), vx = p.column("vx"), vx_err = p.column("vx_error");
  ASSERT_GE(rho, 0);
  ASSERT_GE(vx, 0);
  ASSERT_GE(vx_err, 0);
  double mean_rho = 0;
  for (const auto& row : p.rows) mean_rho += row[static_cast<size_t>(rho)] / 6.0;
  EXPECT_NEAR(mean_rho, 7.0, 1e-9);  // every particle counted exactly once per sample
  double lower = 0, upper = 0;
  for (size_t b = 0; b < 3; ++b) lower += p.rows[b][static_cast<size_t>(vx)];
  for (size_t b = 3; b < 6; ++b) upper += p.rows[b][static_cast<size_t>(vx)];
  EXPECT_GT(lower, 0.0);
  EXPECT_LT(upper, 0.0);
  for (const auto& row : p.rows) EXPECT_GT(row[static_cast<size_t>(vx_err)], 0.0);

  const auto summary = nlohmann::json::parse(mesorock::test::read_file(out / "summary.json"));
  const auto& avg = summary.at("averages");
  EXPECT_NEAR(avg.at("temperature").at("mean").get<double>(), 1.0, 0.1);
  EXPECT_GT(avg.at("temperature").at("error").get<double>(), 0.0);
  EXPECT_EQ(avg.at("temperature").at("samples").get<int>(), 20);  // flow stage: 400 / 20
  for (const char* c : {"xx", "yy", "zz", "xy", "xz", "yz"})
    EXPECT_TRUE(avg.at("stress").contains(c)) << c;
  EXPECT_EQ(summary.at("binned_outputs").at("profile_z").at("samples").get<int>(), 80);
  EXPECT_EQ(summary.at("binned_outputs").at("fields").at("samples").get<int>(), 20);
  EXPECT_EQ(summary.at("units").at("nm_per_rc").get<double>(), 0.852);
  EXPECT_NEAR(summary.at("units").at("si").at("length").at("value").get<double>(), 0.852e-9, 1e-15);
  EXPECT_NE(summary.at("pass").get<std::string>().find("reversed"), std::string::npos);

  const CsvTable thermo = read_csv(out / "thermo.csv");
  EXPECT_EQ(thermo.rows.size(), 25u);  // 500 steps / 20
  EXPECT_GE(thermo.column("sxz"), 0);
}
