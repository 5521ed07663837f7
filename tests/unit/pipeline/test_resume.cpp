// `rockflow run --resume`: a run killed mid-way (SIGKILL, a real process kill after its first
// checkpoint) and resumed ends in the same final particles, bit for bit, with the same thermo,
// profile, region, saturation and slab rows as a run that was never interrupted (CPU backend,
// same thread count). Ctrl-C (SIGINT) leaves a valid checkpoint and exits 130 with a message.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <chrono>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "sim/checkpoint.h"
#include "sim/particle_io.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::TempDir;

namespace {

// The scene (tests/data/scenes/resume_all_outputs.toml): fluid driven along x between a frozen
// wall (wall model) and a rigid slab pushing down, with a virtual wall lifted at step 300, two
// stages with different dt, profiles, fields, a region with saturation and snapshots: every output
// a resumed run has to continue.
const std::string kScene = mesorock::test::read_file(fs::path(MESOROCK_SOURCE_DIR) / "tests" /
                                                     "data" / "scenes" / "resume_all_outputs.toml");

std::string rockflow_run(const fs::path& scene, const fs::path& out, const std::string& extra) {
  return mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
         mesorock::test::shell_quote(scene.string()) + " --out " +
         mesorock::test::shell_quote(out.string()) + " --threads 2 --checkpoint-every 100" + extra;
}

// Starts `rockflow run` as a child process (stderr into err_file), waits until its first
// checkpoint exists, then sends `sig`; returns the wait status.
int run_and_signal(const fs::path& scene, const fs::path& out, const fs::path& err_file, int sig,
                   bool* was_running) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) dup2(fd, 2);
    const std::string exe = MESOROCK_ROCKFLOW;
    execl(exe.c_str(), exe.c_str(), "run", scene.c_str(), "--out", out.c_str(), "--threads", "2",
          "--checkpoint-every", "100", static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto t0 = std::chrono::steady_clock::now();
  *was_running = false;
  int status = 0;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120)) {
    if (waitpid(pid, &status, WNOHANG) == pid) return status;  // ended before a checkpoint
    if (fs::exists(out / "checkpoint.h5")) {
      *was_running = true;
      kill(pid, sig);
      waitpid(pid, &status, 0);
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return status;
}

void expect_same_bits(const std::vector<double>& a, const std::vector<double>& b,
                      const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << what;
}

void expect_same_run(const fs::path& a, const fs::path& b) {
  mesorock::sim::ParticleFileMeta ma, mb;
  const auto pa = mesorock::sim::read_particle_file(a / "final.h5", &ma);
  const auto pb = mesorock::sim::read_particle_file(b / "final.h5", &mb);
  expect_same_bits(pa.x, pb.x, "x");
  expect_same_bits(pa.y, pb.y, "y");
  expect_same_bits(pa.z, pb.z, "z");
  expect_same_bits(pa.vx, pb.vx, "vx");
  expect_same_bits(pa.vy, pb.vy, "vy");
  expect_same_bits(pa.vz, pb.vz, "vz");
  EXPECT_EQ(pa.id, pb.id);
  EXPECT_EQ(ma.step, mb.step);
  EXPECT_EQ(ma.time, mb.time);
  for (const char* f : {"thermo.csv", "profile_z.csv", "regions.csv", "saturation.csv", "slabs.csv",
                        "snapshots/step_000001000.xmf"}) {
    ASSERT_TRUE(fs::exists(b / f)) << f;
    EXPECT_EQ(mesorock::test::read_file(a / f), mesorock::test::read_file(b / f)) << f;
  }
  const auto sa = nlohmann::json::parse(mesorock::test::read_file(a / "summary.json"));
  const auto sb = nlohmann::json::parse(mesorock::test::read_file(b / "summary.json"));
  for (const char* k : {"averages", "binned_outputs", "slabs", "regions", "simulated_time"})
    EXPECT_EQ(sa.at(k), sb.at(k)) << k;
  EXPECT_EQ(sa.at("walls").at("corrections"), sb.at("walls").at("corrections"));
  EXPECT_FALSE(fs::exists(b / "checkpoint.h5")) << "a completed run removes its checkpoint";
  // No temporary files left behind.
  for (const auto& e : fs::directory_iterator(b))
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
}

// One uninterrupted run, shared by the tests: the reference they must match.
class Resume : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    scene_ = *dir_ / "scene.toml";
    std::ofstream(scene_) << kScene;
    const CommandResult r =
        mesorock::test::run_command(rockflow_run(scene_, *dir_ / "whole", ""), dir_->path());
    whole_ok_ = r.exit_code == 0;
    whole_err_ = r.err;
  }
  static void TearDownTestSuite() { delete dir_; }
  void SetUp() override { ASSERT_TRUE(whole_ok_) << whole_err_; }
  static TempDir* dir_;
  static fs::path scene_;
  static bool whole_ok_;
  static std::string whole_err_;
};
TempDir* Resume::dir_ = nullptr;
fs::path Resume::scene_;
bool Resume::whole_ok_ = false;
std::string Resume::whole_err_;

TEST_F(Resume, KilledRunResumesBitForBit) {
  const fs::path out = *dir_ / "killed";
  bool was_running = false;
  const int status = run_and_signal(scene_, out, *dir_ / "killed.err", SIGKILL, &was_running);
  ASSERT_TRUE(was_running) << "the run ended before its first checkpoint: "
                           << mesorock::test::read_file(*dir_ / "killed.err");
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  ASSERT_FALSE(fs::exists(out / "final.h5")) << "killed before the end";
  const auto checkpoint = mesorock::sim::read_checkpoint(out / "checkpoint.h5");
  EXPECT_GT(checkpoint.state.step, 0u);
  EXPECT_LT(checkpoint.state.step, 1250u);
  EXPECT_EQ(checkpoint.state.step % 100, 0u);
  ASSERT_FALSE(kScene.empty());
  EXPECT_EQ(checkpoint.scene_text, kScene);

  const CommandResult r =
      mesorock::test::run_command(rockflow_run(scene_, out, " --resume"), dir_->path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("resumed at step"), std::string::npos) << r.err;
  expect_same_run(*dir_ / "whole", out);
}

TEST_F(Resume, CtrlCLeavesACheckpointAndExits130) {
  const fs::path out = *dir_ / "interrupted";
  bool was_running = false;
  const int status = run_and_signal(scene_, out, *dir_ / "int.err", SIGINT, &was_running);
  ASSERT_TRUE(was_running) << mesorock::test::read_file(*dir_ / "int.err");
  ASSERT_TRUE(WIFEXITED(status)) << "SIGINT must end the run cleanly, not kill it";
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const std::string err = mesorock::test::read_file(*dir_ / "int.err");
  EXPECT_NE(err.find("interrupted: Ctrl-C at step"), std::string::npos) << err;
  EXPECT_NE(err.find("--resume"), std::string::npos) << err;
  const auto checkpoint = mesorock::sim::read_checkpoint(out / "checkpoint.h5");
  EXPECT_GT(checkpoint.state.step, 0u);
  EXPECT_FALSE(fs::exists(out / "final.h5"));
  EXPECT_FALSE(fs::exists(out / ".thermo.csv.partial"));

  // A fresh run into the same folder would discard the checkpoint: refused.
  const CommandResult fresh =
      mesorock::test::run_command(rockflow_run(scene_, out, ""), dir_->path());
  EXPECT_EQ(fresh.exit_code, 2);
  EXPECT_NE(fresh.err.find("--resume"), std::string::npos) << fresh.err;
  // A different scene cannot resume it.
  const fs::path other = *dir_ / "other.toml";
  std::ofstream(other) << kScene + "# changed\n";
  const CommandResult wrong =
      mesorock::test::run_command(rockflow_run(other, out, " --resume"), dir_->path());
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("another scene"), std::string::npos) << wrong.err;

  const CommandResult r =
      mesorock::test::run_command(rockflow_run(scene_, out, " --resume"), dir_->path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_run(*dir_ / "whole", out);
}

TEST(ResumeCli, ResumeWithoutCheckpointIsBadInput) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene) << kScene;
  const CommandResult r =
      mesorock::test::run_command(rockflow_run(scene, dir / "none", " --resume"), dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no checkpoint here"), std::string::npos) << r.err;
}

}  // namespace
