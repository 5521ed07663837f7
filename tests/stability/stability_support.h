#pragma once
// Shared pieces of the stability suite (label "stability"): systems built in code, the outcome of
// a run through the library, and `rockflow run` on the scene files in
// tests/data/scenes/stability/ with its exit code, message and outputs checked.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "mesorock/errors.h"
#include "pipeline/flow/systems.h"
#include "sim/init.h"
#include "sim/particle_io.h"
#include "sim/simulation.h"
#include "support/test_support.h"

namespace mesorock::stability {

namespace fs = std::filesystem;
namespace ms = mesorock::sim;
using pipeline::BuiltSystem;

// One thread per case: ctest runs two cases at a time on CI's two cores (results do not depend on
// the thread count, and one thread per case keeps a busy machine from stalling OpenMP barriers).
inline ms::SimulationOptions cpu_options() {
  ms::SimulationOptions o;
  o.threads = 1;
  return o;
}

// The one-line diagnostic of the watchdog (sim/watchdog.h).
inline bool is_watchdog_message(const std::string& m) {
  static const std::regex re(
      "step [0-9]+: particle -?[0-9]+: (force is not finite|velocity is not finite|position is "
      "not finite|velocity [0-9.e+-]+ exceeds the runaway limit)[^\n]*");
  return std::regex_match(m, re);
}

inline bool all_finite(const ms::ParticleSet& p) {
  for (const auto* a : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz})
    for (double v : *a)
      if (!std::isfinite(v)) return false;
  return true;
}

// Steps `total` in chunks of `every`, calling sample() after each chunk; returns the watchdog's
// message if the run stopped ("" when it ran through).
inline std::string run_sampled(ms::Simulation& sim, std::uint64_t total, std::uint64_t every,
                               const std::function<void()>& sample = {}) {
  try {
    for (std::uint64_t done = 0; done < total; done += every) {
      sim.run(std::min(every, total - done));
      if (sample) sample();
    }
  } catch (const NumericalError& e) {
    return e.what();
  }
  return "";
}

inline double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

// Prints a measured number into the test log (ctest --output-on-failure / -V shows it); the
// numbers quoted in docs/stability.md come from these lines.
inline void report(const std::string& what, double value) {
  std::printf("[ stability ] %s = %.6g\n", what.c_str(), value);
  ::testing::Test::RecordProperty(what, std::to_string(value));
}

// ---------------------------------------------------------------------------------------------
// rockflow run on a scene of tests/data/scenes/stability/.

inline fs::path stability_scene(const std::string& name) {
  return fs::path(MESOROCK_SOURCE_DIR) / "tests/data/scenes/stability" / name;
}

// The scene's text with each {key, value} substitution applied (e.g. {"DT", "0.05"}).
inline std::string scene_text(const std::string& name,
                              const std::vector<std::pair<std::string, std::string>>& subs = {}) {
  std::string text = test::read_file(stability_scene(name));
  EXPECT_FALSE(text.empty()) << stability_scene(name);
  for (const auto& [key, value] : subs) {
    for (size_t at = text.find(key); at != std::string::npos;
         at = text.find(key, at + value.size()))
      text.replace(at, key.size(), value);
  }
  return text;
}

struct CliRun {
  test::CommandResult result;
  fs::path out;
};

// Writes the scene into dir (so relative file paths resolve there) and runs rockflow on it.
inline CliRun rockflow_run(const test::TempDir& dir, const std::string& text,
                           const std::string& extra = "") {
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene) << text;
  CliRun r;
  r.out = dir / "out";
  r.result = test::run_command(test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
                                   test::shell_quote(scene.string()) + " --out " +
                                   test::shell_quote(r.out.string()) + " --threads 1 " + extra,
                               dir.path());
  return r;
}

// Every field of every data row of a CSV output parses as a finite number (stage and name
// columns excepted); returns the number of rows.
inline int expect_finite_csv(const fs::path& csv) {
  std::ifstream in(csv);
  EXPECT_TRUE(in.good()) << csv;
  std::string line;
  int rows = 0;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    ++rows;
    std::stringstream s(line);
    std::string field;
    while (std::getline(s, field, ',')) {
      char* end = nullptr;
      const double v = std::strtod(field.c_str(), &end);
      if (end == field.c_str()) continue;  // a name
      EXPECT_TRUE(std::isfinite(v)) << csv << ": " << line;
    }
  }
  return rows;
}

// After a numerical failure: exit code 3, one line on stderr naming step, particle and quantity,
// and no output file left behind (no thermo.csv, final.h5, summary.json, no temporaries).
inline void expect_numerical_failure(const CliRun& r) {
  EXPECT_EQ(r.result.exit_code, 3) << r.result.err;
  std::string err = r.result.err;
  // Progress lines come first; the failure is the last line.
  while (!err.empty() && err.back() == '\n') err.pop_back();
  const std::string last =
      err.substr(err.rfind('\n') == std::string::npos ? 0 : err.rfind('\n') + 1);
  const std::string prefix = "rockflow: numerical failure: ";
  ASSERT_EQ(last.rfind(prefix, 0), 0u) << r.result.err;
  EXPECT_TRUE(is_watchdog_message(last.substr(prefix.size()))) << last;
  for (const char* f :
       {"thermo.csv", "final.h5", "final.xmf", "summary.json", "regions.csv", "slabs.csv"})
    EXPECT_FALSE(fs::exists(r.out / f)) << f << " was left behind";
  std::error_code ec;
  for (fs::directory_iterator e(r.out, ec), end; !ec && e != end; e.increment(ec))
    EXPECT_EQ(e->path().filename().string().find(".partial"), std::string::npos)
        << e->path() << " was left behind";
}

// After a successful run: exit 0, finite thermo.csv and final particles.
inline ms::ParticleSet expect_clean_run(const CliRun& r) {
  EXPECT_EQ(r.result.exit_code, 0) << r.result.err;
  if (r.result.exit_code != 0) return {};
  EXPECT_GT(expect_finite_csv(r.out / "thermo.csv"), 0);
  const ms::ParticleSet p = ms::read_particle_file(r.out / "final.h5");
  EXPECT_TRUE(all_finite(p));
  return p;
}

// Column `name` of a CSV output, as numbers.
inline std::vector<double> csv_column(const fs::path& csv, const std::string& name) {
  std::ifstream in(csv);
  std::string line;
  int column = -1;
  std::vector<double> out;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream s(line);
    std::string field;
    std::vector<std::string> fields;
    while (std::getline(s, field, ',')) fields.push_back(field);
    if (column < 0) {
      for (size_t k = 0; k < fields.size(); ++k)
        if (fields[k] == name) column = static_cast<int>(k);
      if (column < 0) return out;
      continue;
    }
    if (static_cast<size_t>(column) < fields.size())
      out.push_back(std::strtod(fields[static_cast<size_t>(column)].c_str(), nullptr));
  }
  return out;
}

}  // namespace mesorock::stability
