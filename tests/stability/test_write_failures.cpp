// Write failures (issue 22, item 1; docs/stability.md "Write failures"): the tools run with a
// test-only LD_PRELOAD library (tests/support/write_failure_shim.cpp) that makes the writes to one
// output fail as a full disk does. Every such run must end with exit 2 and a one-line error naming
// the file, and leave no file under a final name that looks complete: the run's outputs appear
// together, summary.json (sweep.json, run.json) last, or not at all. What a failed run keeps: the
// snapshots it finished (each a complete .h5 + .xmf pair) and its last good checkpoint.
//
// Before the fix a disk that filled and emptied again mid-run gave exit 0 over a thermo.csv with
// rows missing and a row cut short; a failed checkpoint close crashed HDF5 at exit (SIGSEGV).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "support/test_support.h"

namespace {

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::run_command;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

const fs::path kScene = fs::path(MESOROCK_SOURCE_DIR) / "tests/data/scenes/resume_all_outputs.toml";

struct Failure {
  std::string file;      // a substring of the path whose writes fail
  long long after = 0;   // bytes the file may take before the "disk" is full
  long long calls = -1;  // failing calls before there is room again (-1: all)
};

std::string with_failure(const Failure& f, const std::string& command) {
  return "env LD_PRELOAD=" + shell_quote(MESOROCK_WRITE_FAILURE_SHIM) +
         " MESOROCK_FAIL_WRITES_TO=" + shell_quote(f.file) +
         " MESOROCK_FAIL_WRITES_AFTER=" + std::to_string(f.after) +
         " MESOROCK_FAIL_WRITES_CALLS=" + std::to_string(f.calls) + " " + command;
}

std::string rockflow_run(const fs::path& out, const std::string& extra = "",
                         int checkpoint_every = 200) {
  return shell_quote(MESOROCK_ROCKFLOW) + " run " + shell_quote(kScene.string()) + " --out " +
         shell_quote(out.string()) + " --threads 1 --checkpoint-every " +
         std::to_string(checkpoint_every) + extra;
}

// Every file under `dir` (relative names), temporaries included.
std::vector<std::string> files_under(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), dir).string());
  return out;
}

// The failure's one-line error names `name`, and the exit code is 2.
void expect_refused_naming(const CommandResult& r, const std::string& name,
                           const std::string& why) {
  EXPECT_EQ(r.exit_code, 2) << why << ":\n" << r.err;
  const std::string last =
      r.err.substr(r.err.rfind("error:") == std::string::npos ? 0 : r.err.rfind("error:"));
  EXPECT_NE(last.find(name), std::string::npos) << why << ": the error names no " << name << ":\n"
                                                << r.err;
  EXPECT_EQ(last.find('\n'), last.size() - 1) << why << ": more than one line:\n" << last;
}

// After a failed `rockflow run`: only the checkpoint and complete snapshot pairs are left, and no
// temporary.
void expect_only_resumable_state(const fs::path& out, const std::string& why) {
  for (const std::string& f : files_under(out)) {
    const fs::path p(f);
    const bool snapshot = p.parent_path() == "snapshots";
    EXPECT_TRUE(f == "checkpoint.h5" || snapshot) << why << ": left " << f;
    EXPECT_EQ(p.filename().string().find(".partial"), std::string::npos) << why << ": left " << f;
    if (snapshot && p.extension() == ".h5") {
      fs::path xmf = out / p;
      EXPECT_TRUE(fs::exists(xmf.replace_extension(".xmf"))) << why << ": " << f << " alone";
    }
  }
}

TEST(WriteFailures, EveryRunOutputFailsTheRunAndLeavesNothingUnderItsName) {
  // Each output of the scene (thermo, regions, saturation, slabs, profile, fields, snapshots,
  // final state, summary), failing after a few bytes.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"thermo.csv", "thermo.csv"},
      {"regions.csv", "regions.csv"},
      {"saturation.csv", "saturation.csv"},
      {"slabs.csv", "slabs.csv"},
      {"profile_z.h5", "profile_z.h5"},
      {"profile_z.csv", "profile_z.csv"},
      {"fields.h5", "fields.h5"},
      {"fields.xmf", "fields.xmf"},
      {"step_000000500.h5", "snapshots/step_000000500.h5"},
      {"step_000001000.xmf", "snapshots/step_000001000.xmf"},
      {"final.h5", "final.h5"},
      {"final.xmf", "final.xmf"},
      {"summary.json", "summary.json"}};
  for (const auto& [file, shown] : cases) {
    TempDir dir;
    const fs::path out = dir / "out";
    const CommandResult r = run_command(with_failure({file, 100}, rockflow_run(out)), dir.path());
    expect_refused_naming(r, (out / shown).string(), file);
    EXPECT_FALSE(fs::exists(out / shown)) << file;
    expect_only_resumable_state(out, file);
  }
}

TEST(WriteFailures, ADiskThatFillsAndEmptiesAgainStillFailsTheRun) {
  // The reported case: space freed a moment after one failed write, no checkpoints. Before the
  // fix: exit 0, "done", and a thermo.csv of 13 lines instead of 27.
  TempDir dir;
  const fs::path out = dir / "out";
  const CommandResult r =
      run_command(with_failure({"thermo.csv", 2000, 1}, rockflow_run(out, "", 0)), dir.path());
  expect_refused_naming(r, (out / "thermo.csv").string(), "transient");
  EXPECT_FALSE(fs::exists(out / "thermo.csv"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  expect_only_resumable_state(out, "transient");
}

TEST(WriteFailures, AFailedCheckpointKeepsTheLastGoodOneAndTheRunResumesFromIt) {
  TempDir dir;
  const fs::path out = dir / "out";
  // A checkpoint of this scene is 100-120 kB: the first fits, the second does not.
  const CommandResult r =
      run_command(with_failure({"checkpoint.h5", 185000}, rockflow_run(out)), dir.path());
  expect_refused_naming(r, (out / "checkpoint.h5").string(), "checkpoint");
  ASSERT_TRUE(fs::exists(out / "checkpoint.h5")) << r.err;
  expect_only_resumable_state(out, "checkpoint");

  const CommandResult resumed = run_command(rockflow_run(out, " --resume"), dir.path());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  // The same result as a run that never failed (resume is exact at one thread).
  const fs::path clean = dir / "clean";
  const CommandResult whole = run_command(rockflow_run(clean), dir.path());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_EQ(mesorock::test::read_file(out / "thermo.csv"),
            mesorock::test::read_file(clean / "thermo.csv"));
  EXPECT_EQ(mesorock::test::read_file(out / "regions.csv"),
            mesorock::test::read_file(clean / "regions.csv"));
}

TEST(WriteFailures, TheShimFailsNothingItIsNotPointedAt) {
  // The control: the same run under the library, pointed at no output, completes; so the
  // failures above come from the failing writes.
  TempDir dir;
  const fs::path out = dir / "out";
  const CommandResult r =
      run_command(with_failure({"no-such-file", 0}, rockflow_run(out)), dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_TRUE(fs::exists(out / "thermo.csv"));
  EXPECT_FALSE(fs::exists(out / "checkpoint.h5"));  // spent when the run completes
}

#ifdef MESOROCK_ROCKPREP
// A tiny synthetic stack -> `rockprep run --layout permeability` without tiles (0.1 s).
std::string rockprep_setup(const TempDir& dir) {
  return shell_quote(MESOROCK_ROCKPREP) + " run " + shell_quote((dir / "stack/grey").string()) +
         " --otsu 3 --rc-per-voxel 0.5 --layout permeability --flow-axis x --wall-fill lattice "
         "--fluid-fill random --threads 1 --seed 7 --out " +
         shell_quote((dir / "setup").string());
}

void make_stack(const TempDir& dir) {
  const CommandResult s = run_command(
      shell_quote(MESOROCK_ROCKPREP) +
          " synth --shape 8,12,16 --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5 "
          "--blob 6 --pore-radius 3 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out " +
          shell_quote((dir / "stack").string()),
      dir.path());
  ASSERT_EQ(s.exit_code, 0) << s.err;
}

TEST(WriteFailures, RockprepRunLeavesNoOutputFolderWhenAnyOfItsFilesFails) {
  TempDir dir;
  make_stack(dir);
  for (const std::string file :
       {"scene.toml", "particles.h5", "particles.xmf", "solid.h5", "tiles.h5", "run.json"}) {
    const CommandResult r = run_command(with_failure({file, 100}, rockprep_setup(dir)), dir.path());
    expect_refused_naming(r, file, file);
    EXPECT_TRUE(files_under(dir / "setup").empty()) << file;
    for (const auto& e : fs::directory_iterator(dir.path()))  // .setup.PID.partial
      EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << file;
  }
  // Into a folder that exists: nothing under a final name, no temporary.
  fs::create_directories(dir / "setup");
  const CommandResult r =
      run_command(with_failure({"particles.h5", 100}, rockprep_setup(dir)), dir.path());
  expect_refused_naming(r, "particles.h5", "existing folder");
  EXPECT_TRUE(files_under(dir / "setup").empty());
}

TEST(WriteFailures, SweepOutputsAppearTogetherOrNotAtAll) {
  TempDir dir;
  make_stack(dir);
  ASSERT_EQ(run_command(rockprep_setup(dir), dir.path()).exit_code, 0);
  const std::string sweep = shell_quote(MESOROCK_ROCKFLOW) + " sweep " +
                            shell_quote((dir / "setup/scene.toml").string()) + " --out " +
                            shell_quote((dir / "sweep").string()) +
                            " --forces 0.1 --viscosity 7 --warmup 100 --block-steps 50 --window 2 "
                            "--measure-blocks 2 --max-steps 600 --threads 1";
  for (const std::string file : {"sweep.csv", "sweep_blocks.csv", "sweep.png", "sweep.json"}) {
    const CommandResult r = run_command(with_failure({file, 100}, sweep), dir.path());
    expect_refused_naming(r, file, file);
    EXPECT_TRUE(files_under(dir / "sweep").empty()) << file;
  }
  const CommandResult ok = run_command(sweep, dir.path());
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(files_under(dir / "sweep").size(), 4u);
}
// Issue 58, item 15: SIGTERM ended `rockflow sweep` and `rockprep run` with 143 and no word
// (this page said 130 and a message). Now both end with 130 and one line saying what was kept,
// and no output takes its final name.
TEST(Signals, SigtermEndsSweepAndRockprepRunWith130AndOneLine) {
  TempDir dir;
  make_stack(dir);
  ASSERT_EQ(run_command(rockprep_setup(dir), dir.path()).exit_code, 0);
  const std::string sweep = shell_quote(MESOROCK_ROCKFLOW) + " sweep " +
                            shell_quote((dir / "setup/scene.toml").string()) + " --out " +
                            shell_quote((dir / "sweep").string()) +
                            " --forces 0.1 --viscosity 7 --warmup 100000 --max-steps 200000"
                            " --threads 1";
  // With tiles built for it (no cache): the set-up takes a while.
  const std::string prep = shell_quote(MESOROCK_ROCKPREP) + " run " +
                           shell_quote((dir / "stack/grey").string()) +
                           " --otsu 3 --rc-per-voxel 0.5 --layout permeability --flow-axis x "
                           "--tile-cache none --threads 1 --seed 7 --out " +
                           shell_quote((dir / "prep").string());
  for (const auto& [command, tool, out] :
       {std::tuple<std::string, std::string, std::string>{sweep, "rockflow", "sweep"},
        {prep, "rockprep", "prep"}}) {
    const CommandResult r =
        run_command("timeout --preserve-status -s TERM 2 " + command, dir.path());
    EXPECT_EQ(r.exit_code, 130) << tool << ": " << r.err;
    std::string err = r.err;
    while (!err.empty() && err.back() == '\n') err.pop_back();
    const std::string last =
        err.substr(err.rfind('\n') == std::string::npos ? 0 : err.rfind('\n') + 1);
    EXPECT_EQ(last.rfind(tool + ": interrupted: SIGTERM: nothing was written to ", 0), 0u)
        << tool << ": " << r.err;
    for (const std::string& f : files_under(dir / out))
      EXPECT_EQ(fs::path(f).filename().string().rfind(".", 0), 0u)  // temporaries, the lock
          << tool << ": " << f << " under its final name";
  }
}
#endif

}  // namespace
