// rockflow study (the accuracy-versus-time study) at the tiny size, and its report generator: the
// outputs parse and hold every study, with provenance, and the report page shows every study.
// Speed is never asserted (tests measure no speed); the round-off check is: the cell-list
// settings must give the same trajectory to round-off.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "support/test_support.h"

namespace {

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::read_file;
using mesorock::test::run_command;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

// Rows of a CSV written by the study: lines that are neither comments nor the header.
int csv_rows(const fs::path& path) {
  std::istringstream in(read_file(path));
  int rows = 0;
  bool header = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    ++rows;
  }
  return rows;
}

// A Python 3 with numpy and matplotlib (scripts/setup.sh installs python3-matplotlib), or "".
std::string python_with_matplotlib(const fs::path& scratch) {
  for (const char* py : {"/usr/bin/python3", "python3"}) {
    const CommandResult r =
        run_command(std::string(py) + " -c 'import numpy, matplotlib'", scratch);
    if (r.exit_code == 0) return py;
  }
  return "";
}

TEST(StudyCommand, TinyRunHoldsEveryStudyAndTheReportShowsThem) {
  TempDir dir;
  const fs::path out = dir / "study";
  const CommandResult r = run_command(shell_quote(MESOROCK_ROCKFLOW) + " study --size tiny " +
                                          "--threads 1 --out " + shell_quote(out.string()),
                                      dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("study: "), std::string::npos) << "progress goes to stderr";

  const auto j = nlohmann::json::parse(read_file(out / "study.json"));
  for (const char* k : {"mesorock_version", "git_commit", "date", "device", "backend", "size",
                        "seed", "command", "host"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["size"], "tiny");
  EXPECT_EQ(j["backend"], "cpu");
  const auto& studies = j["studies"];
  for (const char* name : {"timestep", "precision", "resolution", "reorder", "effects"}) {
    ASSERT_TRUE(studies.contains(name)) << name;
    const auto& s = studies[name];
    EXPECT_TRUE(s.contains("parameters")) << name;
    ASSERT_FALSE(s["rows"].empty()) << name;
    const fs::path csv = out / s["csv"].get<std::string>();
    ASSERT_TRUE(fs::exists(csv)) << csv;
    EXPECT_EQ(csv_rows(csv), static_cast<int>(s["rows"].size())) << csv;
    EXPECT_EQ(read_file(csv).rfind("# mesorock ", 0), 0u) << "provenance line first in " << csv;
  }

  // Time step: every dt of the issue, each with the accuracy columns and a cost.
  std::set<double> dts;
  for (const auto& row : studies["timestep"]["rows"]) {
    dts.insert(row["dt"].get<double>());
    for (const char* k :
         {"temperature", "pressure", "pressure_vs_warren", "viscosity", "permeability",
          "permeability_vs_reference_dt", "ns_per_particle_tau", "mps_at_scale", "stable"})
      EXPECT_TRUE(row.contains(k)) << k;
  }
  EXPECT_EQ(dts, (std::set<double>{0.005, 0.01, 0.02, 0.03, 0.04}));
  // The smallest time step is stable and is its own reference.
  const auto& first = studies["timestep"]["rows"][0];
  ASSERT_TRUE(first["stable"].get<bool>());
  EXPECT_DOUBLE_EQ(first["permeability_vs_reference_dt"].get<double>(), 0.0);

  std::set<std::string> precisions;
  for (const auto& row : studies["precision"]["rows"])
    precisions.insert(row["precision"].get<std::string>());
  EXPECT_EQ(precisions, (std::set<std::string>{"single", "double"}));

  std::set<double> widths;
  for (const auto& row : studies["resolution"]["rows"]) {
    widths.insert(row["width"].get<double>());
    EXPECT_NEAR(row["stokes_permeability"].get<double>(),
                row["width"].get<double>() * row["width"].get<double>() / 12, 1e-12);
  }
  EXPECT_EQ(widths, (std::set<double>{2, 3, 4, 6, 8}));

  // Reorder interval and skin: both systems, a configuration with an interval, and the same
  // trajectory to round-off (double precision, from the same state).
  std::set<std::string> systems;
  bool interval = false;
  for (const auto& row : studies["reorder"]["rows"]) {
    systems.insert(row["system"].get<std::string>());
    interval = interval || row["reorder_every"].get<int>() > 1;
  }
  EXPECT_EQ(systems, (std::set<std::string>{"bulk", "porous"}));
  EXPECT_TRUE(interval);
  EXPECT_LT(studies["reorder"]["summary"]["check_max_position_difference"].get<double>(), 1e-9);

  // Effects: the bare pass at least 5 times, every effect, and the inactive forms.
  int bare = 0;
  std::set<std::string> scenes;
  for (const auto& row : studies["effects"]["rows"]) {
    const std::string name = row["scene"].get<std::string>();
    if (name.rfind("bare", 0) == 0)
      ++bare;
    else
      scenes.insert(name);
    EXPECT_TRUE(row.contains("within_bare_noise")) << name;
  }
  EXPECT_GE(bare, 5);
  for (const char* s :
       {"mdpd", "thermostat", "body_force", "wall_model", "virtual_wall", "rigid_slab", "injection",
        "stress", "profile", "region_counts", "region_pressure", "virtual_wall_passed",
        "injection_never_due", "observables_never_sampled"})
    EXPECT_TRUE(scenes.count(s)) << s;
  EXPECT_TRUE(studies["effects"]["summary"].contains("bare_ms_per_step_sd"));

  // The report: one page with every study, its plots, and the raw data beside it.
  const std::string py = python_with_matplotlib(dir.path());
  ASSERT_FALSE(py.empty()) << "needs python3 with numpy and matplotlib (scripts/setup.sh)";
  const fs::path page = dir / "page";
  const CommandResult rep = run_command(
      py + " " + shell_quote(std::string(MESOROCK_SOURCE_DIR) + "/scripts/accuracy_report.py") +
          " --study " + shell_quote((out / "study.json").string()) + " --out " +
          shell_quote(page.string()),
      dir.path());
  ASSERT_EQ(rep.exit_code, 0) << rep.err;
  const std::string md = read_file(page / "accuracy.md");
  for (const char* heading :
       {"## 1. Time step", "## 2. Single against double precision",
        "## 3. Lattice against tile packing", "## 4. Resolution", "## 5. Reorder interval",
        "## 6. What each effect costs", "Not measured in this run", "`tiny` size"})
    EXPECT_NE(md.find(heading), std::string::npos) << heading;
  EXPECT_NE(md.find(j["git_commit"].get<std::string>()), std::string::npos);
  for (const char* png : {"timestep.png", "resolution.png", "reorder.png", "effects.png"})
    EXPECT_GT(fs::file_size(page / "accuracy" / png), 1000u) << png;
  EXPECT_TRUE(fs::exists(page / "accuracy" / "study.json"));
}

TEST(StudyCommand, UnknownStudyIsBadInput) {
  TempDir dir;
  const CommandResult r =
      run_command(shell_quote(MESOROCK_ROCKFLOW) + " study --size tiny --only nonsense --out " +
                      shell_quote((dir / "s").string()),
                  dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown study"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "s" / "study.json"));
}

}  // namespace
