// Outputs that take their final names together (issue 58, items 7 and 8). When one final name
// was taken (a folder named sweep.json, say), the outputs renamed before it stayed under their
// final names; and a sweep, relperm or pc that failed left the previous run's completion record
// in place, where a script waiting for it read the old numbers.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "mesorock/errors.h"
#include "mesorock/staged_outputs.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

namespace {

bool any_temporary(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".partial") != std::string::npos) return true;
  return false;
}

TEST(AllOrNothing, AFinalNameTakenByAFolderLeavesNoOutputUnderItsName) {
  TempDir dir;
  fs::create_directories(dir / "b.csv" / "inside");
  {
    mesorock::StagedOutputs outputs = mesorock::StagedOutputs::files();
    outputs.write_text(dir / "a.csv", "a\n");
    outputs.write_text(dir / "b.csv", "b\n");
    outputs.write_text(dir / "c.json", "{}\n");
    try {
      outputs.commit();
      ADD_FAILURE() << "a folder took the name of an output";
    } catch (const mesorock::IoError& e) {
      EXPECT_NE(std::string(e.what()).find("b.csv"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "a.csv")) << "renamed before the one that could not be";
    EXPECT_FALSE(fs::exists(dir / "c.json"));
  }
  EXPECT_FALSE(any_temporary(dir.path()));
  EXPECT_TRUE(fs::is_directory(dir / "b.csv" / "inside"));
}

const std::string kScene =
    "name = \"whole\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [4.0, 4.0, 4.0]\n"
    "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
    "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
    "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"water\"\n"
    "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
    "[[init]]\nkind = \"random\"\ntype = \"water\"\ncount = 300\n"
    "[[run]]\nsteps = 20\ndt = 0.01\n[output]\nthermo_every = 5\n";

CommandResult rockflow(const TempDir& dir, const std::string& args) {
  return mesorock::test::run_command("cd " + shell_quote(dir.path().string()) + " && " +
                                         shell_quote(MESOROCK_ROCKFLOW) + " " + args,
                                     dir.path());
}

// `rockflow run` into a folder where summary.json is a folder: thermo.csv and final.* took their
// names before the failure.
TEST(AllOrNothing, RunWhoseRecordNameIsAFolderLeavesNoOutput) {
  TempDir dir;
  std::ofstream(dir / "scene.toml") << kScene;
  fs::create_directories(dir / "out" / "summary.json" / "inside");
  const CommandResult r = rockflow(dir, "run scene.toml --out out --threads 1");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("summary.json"), std::string::npos) << r.err;
  for (const char* f : {"thermo.csv", "final.h5", "final.xmf"})
    EXPECT_FALSE(fs::exists(dir / "out" / f)) << f << " was left under its final name";
  EXPECT_FALSE(any_temporary(dir / "out"));
}

// A sweep, relperm or pc that fails (here: a sample with no driven type, or no slabs) removes the
// earlier record first, as `rockflow run` does with summary.json.
TEST(AllOrNothing, AFailedSweepRelpermOrPcLeavesNoEarlierRecord) {
  TempDir dir;
  std::ofstream(dir / "frozen.toml")
      << "name = \"frozen\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [4.0, 4.0, 4.0]\n"
         "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
         "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
         "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"wall\"\nfrozen = true\n"
         "[[pairs]]\ntypes = [\"wall\", \"wall\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
         "[[init]]\nkind = \"lattice\"\ntype = \"wall\"\ndensity = 3.0\n"
         "[[run]]\nsteps = 10\ndt = 0.01\n";
  for (const auto& [command, record] :
       {std::pair<std::string, std::string>{
            "sweep frozen.toml --forces 0.01 --fluid-density 3 --viscosity 1", "sweep.json"},
        {"relperm frozen.toml --saturations 0.5", "relperm.json"},
        {"pc frozen.toml --pressures 1", "pc.json"}}) {
    fs::create_directories(dir / "out");
    std::ofstream(dir / "out" / record) << "{\"old\": true}\n";
    const CommandResult r = rockflow(dir, command + " --out out --threads 1");
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out" / record)) << command << ": the old record was kept";
  }
}

}  // namespace
