// One owner per output folder (issue 58, item 1; common/mesorock/output_lock.h): a folder held by
// one process is refused to every other command that writes it, at once, naming the folder and
// the holder's pid. The concurrent start of two real runs is in the stability suite
// (tests/stability/test_concurrent_runs.cpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>

#include "mesorock/errors.h"
#include "mesorock/output_lock.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

namespace {

const std::string kScene =
    "name = \"lock\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [4.0, 4.0, 4.0]\n"
    "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
    "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
    "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"water\"\nbody_force = [0.01, 0.0, 0.0]\n"
    "[[types]]\nname = \"wall\"\nfrozen = true\n"
    "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
    "[[pairs]]\ntypes = [\"water\", \"wall\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
    "[[pairs]]\ntypes = [\"wall\", \"wall\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
    "[[init]]\nkind = \"random\"\ntype = \"water\"\ncount = 200\nlo = [0.0, 0.0, 1.0]\n"
    "[[init]]\nkind = \"lattice\"\ntype = \"wall\"\ndensity = 4.0\nhi = [4.0, 4.0, 1.0]\n"
    "[[run]]\nsteps = 10\ndt = 0.01\n[output]\nthermo_every = 5\n";

TEST(OutputLock, ASecondOwnerIsRefusedNamingTheFolderAndThePid) {
  TempDir dir;
  const fs::path out = dir / "a" / "out";
  {
    const mesorock::OutputLock first(out);
    EXPECT_TRUE(fs::is_directory(out)) << "the folder is made when missing";
    EXPECT_TRUE(fs::exists(out / mesorock::OutputLock::kFileName));
    try {
      const mesorock::OutputLock second(out);
      ADD_FAILURE() << "two owners of one folder";
    } catch (const mesorock::ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(out.string()), std::string::npos) << what;
      EXPECT_NE(what.find("pid " + std::to_string(getpid())), std::string::npos) << what;
    }
  }
  // Released: the lock file is gone, and so is the folder the lock made, which stayed empty.
  EXPECT_FALSE(fs::exists(out));
  fs::create_directories(out);
  std::ofstream(out / "kept.txt") << "x";
  std::ofstream(out / ".thermo.csv.999999.partial") << "left by a killed run";
  {
    const mesorock::OutputLock again(out);
    EXPECT_FALSE(fs::exists(out / ".thermo.csv.999999.partial")) << "a stale temporary is removed";
  }
  EXPECT_TRUE(fs::exists(out / "kept.txt"));
  EXPECT_FALSE(fs::exists(out / mesorock::OutputLock::kFileName));
  // A folder that is a file, or under a file, is named.
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(mesorock::OutputLock(dir / "file"), mesorock::IoError);
  EXPECT_THROW(mesorock::OutputLock(dir / "file" / "sub"), mesorock::IoError);
}

// Every command of rockflow that writes a folder takes the lock before its work: with the
// folder held here, each is refused at once with exit 2, naming the folder and this pid.
TEST(OutputLock, EveryRockflowCommandIsRefusedAFolderInUse) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene) << kScene;
  const fs::path out = dir / "held";
  const mesorock::OutputLock held(out);
  const std::string s = shell_quote(scene.string()), o = " --out " + shell_quote(out.string());
  for (const std::string& args :
       {"run " + s + o + " --threads 1",
        "sweep " + s + o + " --forces 0.01 --fluid-density 4 --viscosity 1 --threads 1",
        "relperm " + s + o + " --saturations 0.5 --threads 1",
        "pc " + s + o + " --pressures 1 --threads 1"}) {
    const auto t0 = std::chrono::steady_clock::now();
    const CommandResult r =
        mesorock::test::run_command("cd " + shell_quote(dir.path().string()) + " && " +
                                        shell_quote(MESOROCK_ROCKFLOW) + " " + args,
                                    dir.path());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(
        r.err.find(out.string() + ": in use by another process (pid " + std::to_string(getpid())),
        std::string::npos)
        << args << ": " << r.err;
    EXPECT_LT(seconds, 5.0) << args;
  }
  EXPECT_FALSE(fs::exists(out / "thermo.csv"));
}

}  // namespace
