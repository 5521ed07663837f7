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

// `rockflow run SCENE --out DIR/out --threads N` in DIR.
CommandResult run_scene(const TempDir& dir, const fs::path& scene, int threads) {
  return mesorock::test::run_command(mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
                                         mesorock::test::shell_quote(scene.string()) + " --out " +
                                         mesorock::test::shell_quote((dir / "out").string()) +
                                         " --threads " + std::to_string(threads),
                                     dir.path());
}

}  // namespace

TEST(RunOutputs, EveryFileOpensAndHoldsTheAveragedObservables) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  {
    std::ofstream f(scene);
    f << kScene;
  }
  const CommandResult r = run_scene(dir, scene, 2);
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

// Flooding outputs: a virtual wall at x = 4 keeps the working fluid out of the block x in [4, 8)
// until step 200; a body force then pushes it in. regions.csv counts each type in the block and
// gives the flow rate through a thin slab; saturation.csv follows the source fluid's share.
TEST(RunOutputs, RegionsSaturationAndVirtualWall) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  {
    std::ofstream f(scene);
    f << R"(name = "flood"
seed = 4
[box]
lo = [0.0, 0.0, 0.0]
hi = [8.0, 4.0, 4.0]
[model]
conservative = "mdpd"
[[types]]
name = "source"
body_force = [0.05, 0.0, 0.0]
[[types]]
name = "working"
body_force = [0.05, 0.0, 0.0]
[[pairs]]
types = ["source", "source"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "working"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "working"]
A = -40.0
B = 25.0
gamma = 4.5
[[virtual_walls]]
axis = "x"
position = 4.0
types = ["working"]
keep = "below"
until_step = 200
[[init]]
kind = "random"
type = "working"
density = 6.5
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 4.0]
[[init]]
kind = "random"
type = "source"
density = 6.5
lo = [4.0, 0.0, 0.0]
hi = [8.0, 4.0, 4.0]
[[run]]
steps = 800
dt = 0.01
[output]
thermo_every = 0
final_snapshot = false
[[output.regions]]
name = "block"
lo = [4.0, 0.0, 0.0]
hi = [8.0, 4.0, 4.0]
every = 50
saturation_of = "source"
[[output.regions]]
name = "plane"
lo = [1.75, 0.0, 0.0]
hi = [2.25, 4.0, 4.0]
every = 50
types = ["working"]
)";
  }
  const CommandResult r = run_scene(dir, scene, 2);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path out = dir / "out";
  std::stringstream rows(mesorock::test::read_file(out / "regions.csv"));
  std::string line;
  int samples = 0;
  double working_in_block_late = 0, flow_sum = 0;
  while (std::getline(rows, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("step,", 0) == 0) continue;
    const auto c = split(line);
    ASSERT_EQ(c.size(), 10u) << line;
    const double step = std::stod(c[0]), count = std::stod(c[5]);
    if (c[3] == "block" && c[4] == "working") {
      ++samples;
      if (step <= 200)
        EXPECT_EQ(count, 0.0) << "working fluid crossed the virtual wall at " << step;
      if (step == 800) working_in_block_late = count;
    }
    if (c[3] == "plane" && step > 200) flow_sum += std::stod(c[7]);
  }
  EXPECT_EQ(samples, 17);  // steps 0, 50, ..., 800
  EXPECT_GT(working_in_block_late, 0.0) << "the wall was not removed at step 200";
  EXPECT_GT(flow_sum, 0.0) << "the body force drives the fluid along +x";
  const CsvTable sat = read_csv(out / "saturation.csv");
  ASSERT_EQ(sat.rows.size(), 17u);
  const int s = sat.column("saturation"), rec = sat.column("recovery");
  ASSERT_GE(s, 0);
  EXPECT_DOUBLE_EQ(sat.rows.front()[static_cast<size_t>(s)], 1.0);
  EXPECT_LT(sat.rows.back()[static_cast<size_t>(s)], 1.0);
  for (const auto& row : sat.rows)
    EXPECT_NEAR(row[static_cast<size_t>(rec)], 1.0 - row[static_cast<size_t>(s)],
                1e-9);  // 10 digits
  const auto summary = nlohmann::json::parse(mesorock::test::read_file(out / "summary.json"));
  EXPECT_TRUE(summary.at("regions").at("last_sample").contains("block"));
  for (const auto& e : std::filesystem::directory_iterator(out))  // .NAME.PID.partial
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
}

// [[injection]] through `rockflow run`: injection.csv counts the moved particles, the summary has
// the totals, and a region with pressure = true writes region_pressure.csv.
TEST(RunOutputs, InjectionAndRegionPressure) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  {
    std::ofstream f(scene);
    f << R"(name = "inject"
seed = 6
[box]
lo = [0.0, 0.0, 0.0]
hi = [10.0, 4.0, 4.0]
boundary = ["reflective", "periodic", "periodic"]
[model]
conservative = "dpd"
[[types]]
name = "source"
[[types]]
name = "working"
[[pairs]]
types = ["source", "source"]
a = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "working"]
a = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "working"]
a = 25.0
gamma = 4.5
[[injection]]
type = "working"
inlet_lo = [0.0, 0.0, 0.0]
inlet_hi = [2.0, 4.0, 4.0]
outlet_lo = [8.0, 0.0, 0.0]
outlet_hi = [10.0, 4.0, 4.0]
every = 4
start_step = 20
[[init]]
kind = "random"
type = "source"
density = 3.0
[[run]]
steps = 200
dt = 0.01
[output]
thermo_every = 50
final_snapshot = false
[[output.regions]]
name = "middle"
lo = [3.0, 0.0, 0.0]
hi = [7.0, 4.0, 4.0]
every = 50
pressure = true
)";
  }
  const CommandResult r = run_scene(dir, scene, 2);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path out = dir / "out";
  const CsvTable inj = read_csv(out / "injection.csv");
  ASSERT_EQ(inj.rows.size(), 4u);  // thermo rows at 50, 100, 150, 200
  const int injected = inj.column("injected"), missed = inj.column("missed");
  ASSERT_GE(injected, 0);
  // Events at steps 24, 28, ..., 200 (after start_step = 20): 45 in all, 7 by step 50.
  EXPECT_EQ(inj.rows.front()[static_cast<size_t>(injected)], 7.0);
  EXPECT_EQ(
      inj.rows.back()[static_cast<size_t>(injected)] + inj.rows.back()[static_cast<size_t>(missed)],
      45.0);
  const auto summary = nlohmann::json::parse(mesorock::test::read_file(out / "summary.json"));
  EXPECT_EQ(summary.at("injection").at(0).at("injected").get<int>() +
                summary.at("injection").at(0).at("missed_events").get<int>(),
            45);
  const CsvTable p = read_csv(out / "region_pressure.csv");
  ASSERT_EQ(p.rows.size(), 5u);  // steps 0, 50, ..., 200
  const int pc = p.column("pressure");
  ASSERT_GE(pc, 0);
  for (const auto& row : p.rows)  // a DPD fluid at rho = 3: p about 23.65 (Groot & Warren)
    EXPECT_GT(row[static_cast<size_t>(pc)], 5.0);
  EXPECT_TRUE(summary.at("regions").at("last_sample").at("middle").contains("pressure"));
}

// summary.json gives the fluid's throughput beside MPS/s: frozen particles count in `particles`
// and `mps`, not in `mobile_particles` and `mobile_mps`.
TEST(RunOutputs, SummaryCountsTheMobileParticlesApartFromTheFrozenOnes) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  {
    std::ofstream f(scene);
    f << R"(name = "mobile"
seed = 3
[box]
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 4.0]
[model]
conservative = "mdpd"
[[types]]
name = "water"
[[types]]
name = "wall"
frozen = true
[[pairs]]
types = ["water", "water"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["water", "wall"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["wall", "wall"]
A = 0.0
B = 0.0
gamma = 0.0
[[init]]
kind = "random"
type = "wall"
count = 70
hi = [4.0, 4.0, 1.0]
[[init]]
kind = "random"
type = "water"
count = 250
lo = [0.0, 0.0, 1.0]
[[run]]
steps = 20
dt = 0.005
[output]
thermo_every = 10
)";
  }
  const CommandResult r = run_scene(dir, scene, 1);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary =
      nlohmann::json::parse(mesorock::test::read_file(dir / "out" / "summary.json"));
  EXPECT_EQ(summary.at("particles").get<int>(), 320);
  EXPECT_EQ(summary.at("mobile_particles").get<double>(), 250.0);
  const double mps = summary.at("mps").get<double>();
  ASSERT_GT(mps, 0.0);
  EXPECT_NEAR(summary.at("mobile_mps").get<double>(), mps * 250.0 / 320.0, 1e-9 * mps);
  EXPECT_NE(r.err.find("million mobile-particle-steps/s"), std::string::npos) << r.err;
  // Without a solid grid's bounce no frozen particle may leave the steps (HostState::may_bury).
  EXPECT_EQ(summary.at("buried_particles").get<int>(), 0);
  // Where the time went: stepping and the thermo rows (3 of them), within the run's seconds.
  const auto& split = summary.at("time_split");
  const double stepping = split.at("steps_seconds").get<double>();
  const double outputs = split.at("outputs_seconds").get<double>();
  EXPECT_GT(stepping, 0.0);
  EXPECT_GT(split.at("outputs").at("thermo").get<double>(), 0.0);
  double each = 0;
  for (const auto& [name, seconds] : split.at("outputs").items()) each += seconds.get<double>();
  EXPECT_NEAR(outputs, each, 1e-12 + 1e-9 * outputs);
  EXPECT_LE(stepping + outputs, summary.at("run_seconds").get<double>() * (1 + 1e-9));
  EXPECT_NE(r.err.find("stepping"), std::string::npos) << r.err;
}

// A region's flow rate over the averaged stages, and whether it was steady (the sweep's halves
// test on its samples): a liquid that a uniform force accelerates in a periodic box (its momentum
// grows as N g t, so the flow rate triples from the first half to the second) is still changing;
// reverse Poiseuille flow after 15 relaxation times of the half-box (d^2 / (pi^2 nu), about 1)
// is steady. A region with no driven type gets averages but no verdict.
TEST(RunOutputs, RegionsSayWhetherTheirFlowWasSteady) {
  struct Case {
    const char* name;
    const char* model;  // the [model] lines past conservative
    int spin_up, flow;
    bool steady;
  };
  for (const Case& c :
       {Case{"accelerating", "", 1, 300, false},
        Case{"reverse_poiseuille", "body_force_profile = \"reversed\"\nbody_force_axis = \"z\"\n",
             1500, 1000, true}}) {
    SCOPED_TRACE(c.name);
    TempDir dir;
    const fs::path scene = dir / "scene.toml";
    {
      std::ofstream f(scene);
      f << "name = \"" << c.name << "\"\nseed = 9\n"
        << R"([box]
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 6.0]
[model]
conservative = "mdpd"
)" << c.model
        << R"([[types]]
name = "water"
body_force = [0.2, 0.0, 0.0]
[[types]]
name = "tracer"
[[pairs]]
types = ["water", "water"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["water", "tracer"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["tracer", "tracer"]
A = -40.0
B = 25.0
gamma = 4.5
[[init]]
kind = "random"
type = "water"
density = 7.0
[[init]]
kind = "random"
type = "tracer"
count = 5
[[run]]
name = "spin_up"
)"
        << "steps = " << c.spin_up << "\ndt = 0.01\n[[run]]\nname = \"flow\"\nsteps = " << c.flow
        << R"(
dt = 0.01
[output]
thermo_every = 0
final_snapshot = false
average_stages = ["flow"]
[[output.regions]]
name = "lower"
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 3.0]
every = 10
types = ["water"]
[[output.regions]]
name = "tracers"
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 6.0]
every = 10
types = ["tracer"]
)";
    }
    const CommandResult r = run_scene(dir, scene, 2);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto summary =
        nlohmann::json::parse(mesorock::test::read_file(dir / "out" / "summary.json"));
    const auto& lower = summary.at("regions").at("averages").at("lower");
    EXPECT_EQ(lower.at("samples").get<int>(), c.flow / 10);  // the flow stage's samples only
    const auto& verdict = lower.at("steady").at("x");
    EXPECT_TRUE(verdict.at("judged").get<bool>());
    EXPECT_EQ(verdict.at("steady").get<bool>(), c.steady) << verdict.dump();
    EXPECT_FALSE(lower.at("steady").contains("y"));  // no force along y
    const double first = verdict.at("first_half_mean").get<double>();
    const double second = verdict.at("second_half_mean").get<double>();
    const double mean = lower.at("flow_rate").at(0).at("mean").get<double>();
    EXPECT_NEAR(mean, 0.5 * (first + second), 1e-9 * std::abs(mean));
    const double change = verdict.at("change").get<double>();
    const double change_error = verdict.at("change_error").get<double>();
    if (!c.steady) {
      EXPECT_GT(second, 2 * first);
      // A ramp from rest: the block means go as 0.5, 1.5, ..., 9.5, so the trend across them is
      // 9 / 5 = 1.8 times their mean.
      EXPECT_TRUE(verdict.at("trend_significant").get<bool>());
      EXPECT_GT(change, 1.0);
    } else {
      EXPECT_FALSE(verdict.at("trend_significant").get<bool>());
      EXPECT_LT(std::abs(change), 3 * change_error + 0.05);
    }
    EXPECT_NE(r.err.find(c.steady ? "region lower: flow rate along x" : "still changing"),
              std::string::npos)
        << r.err;
    // The tracers feel no force: averaged, not judged.
    const auto& tracers = summary.at("regions").at("averages").at("tracers");
    EXPECT_FALSE(tracers.contains("steady"));
    EXPECT_EQ(r.err.find("region tracers"), std::string::npos) << r.err;
  }
}
