// rockflow's command line: exit codes and one-line errors that do not depend on a scene file.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "sim/simulation.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code = -1;
  std::string out, err;
};

Result rockflow(const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / ("rockflow_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string cmd = std::string(MESOROCK_ROCKFLOW) + " " + args + " >" +
                          (dir / "out").string() + " 2>" + (dir / "err").string();
  const int status = std::system(cmd.c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  Result r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir / "out"), slurp(dir / "err")};
  fs::remove_all(dir);
  return r;
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
    const Result r = rockflow(args);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(lines(r.err), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find("cuda"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST(RockflowCli, ValidateListsTheCasesOnePerLine) {
  const Result r = rockflow("validate --list");
  EXPECT_EQ(r.code, 0);
  for (const char* c : {"eos-dpd\n", "eos-mdpd\n", "conservation\n"})
    EXPECT_NE(r.out.find(c), std::string::npos) << r.out;
}

TEST(RockflowCli, BadUsageExitsTwo) {
  EXPECT_EQ(rockflow("validate no-such-case").code, 2);
  EXPECT_EQ(rockflow("validate conservation --size huge").code, 2);
  EXPECT_EQ(rockflow("bench --case nowhere").code, 2);
  EXPECT_EQ(rockflow("run /no/such/scene.toml").code, 2);
  EXPECT_EQ(rockflow("--version").code, 0);
}

TEST(RockflowCli, BenchJsonHasTheAgreedFields) {
  const Result r = rockflow("bench --case porous --particles 2000 --steps 3 --threads 1 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* k : {"\"mps\"", "\"particles\"", "\"steps\"", "\"backend\"", "\"seconds\""})
    EXPECT_NE(r.out.find(k), std::string::npos) << k << " in " << r.out;
}

}  // namespace
