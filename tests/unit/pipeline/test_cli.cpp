// rockflow's command line: exit codes and one-line errors that do not depend on a scene file.
#include <gtest/gtest.h>

#include <string>

#include "sim/simulation.h"
#include "support/test_support.h"

namespace {

using mesorock::test::CommandResult;

CommandResult rockflow(const std::string& args) {
  mesorock::test::TempDir dir;
  return mesorock::test::run_command(mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " " + args,
                                     dir.path());
}

int lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST(RockflowCli, CudaWithoutDeviceFailsWithOneLineAndExitTwo) {
  if (mesorock::sim::cuda_unavailable_reason().empty())
    GTEST_SKIP() << "a CUDA device is present: nothing to refuse";
  for (const std::string args : {"validate conservation --backend cuda",
                                 "bench --backend cuda --particles 2000 --steps 2"}) {
    const CommandResult r = rockflow(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(lines(r.err), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find("cuda"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST(RockflowCli, ValidateListsTheCasesOnePerLine) {
  const CommandResult r = rockflow("validate --list");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* c : {"eos-dpd\n", "eos-mdpd\n", "conservation\n", "slab\n", "viscosity\n"})
    EXPECT_NE(r.out.find(c), std::string::npos) << r.out;
}

TEST(RockflowCli, BadUsageExitsTwo) {
  EXPECT_EQ(rockflow("validate no-such-case").exit_code, 2);
  EXPECT_EQ(rockflow("validate conservation --size huge").exit_code, 2);
  EXPECT_EQ(rockflow("bench --case nowhere").exit_code, 2);
  // Negative counts used to wrap to 2^64 - 1 (bench --steps -1 hung): refused at parse time.
  for (const char* args : {"bench --steps -1", "bench --particles -5", "bench --steps 1e300",
                           "bench --threads 100000"}) {
    const CommandResult r = rockflow(args);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(args).substr(6, 7)), std::string::npos)
        << args << ": " << r.err;
  }
  EXPECT_EQ(rockflow("run /no/such/scene.toml").exit_code, 2);
  EXPECT_EQ(rockflow("--version").exit_code, 0);
}

TEST(RockflowCli, BenchJsonHasTheAgreedFields) {
  const CommandResult r =
      rockflow("bench --case porous --particles 2000 --steps 3 --threads 1 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* k : {"\"mps\"", "\"particles\"", "\"steps\"", "\"backend\"", "\"seconds\""})
    EXPECT_NE(r.out.find(k), std::string::npos) << k << " in " << r.out;
}

// Issue 58, item 16: CLI11's usage errors were two lines without "rockflow:", and a range check
// wrote the largest double with all its 309 digits ("--threads -1"). One line now, in the form of
// every other error.
TEST(RockflowCli, UsageErrorsAreOneLineNamingTheOption) {
  for (const auto& [args, what] :
       {std::pair<std::string, std::string>{"bench --threads -1", "--threads: "},
        {"run x.toml --runaway-displacement -1", "--runaway-displacement: "},
        {"run x.toml --checkpoint-every -5", "--checkpoint-every: "},
        {"run", "scene"},
        {"run x.toml --bogus", "--bogus"},
        {"", "subcommand"}}) {
    const CommandResult r = rockflow(args);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_EQ(lines(r.err), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("rockflow: error: ", 0), 0u) << args << ": " << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << args << ": " << r.err;
    EXPECT_LT(r.err.size(), 200u) << args << ": " << r.err;
  }
}

}  // namespace
