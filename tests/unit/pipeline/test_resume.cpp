// `rockflow run --resume`: a run killed mid-way (SIGKILL, a real process kill after its first
// checkpoint) and resumed ends in the same final particles, bit for bit, with the same thermo,
// profile, region, saturation and slab rows as a run that was never interrupted (CPU backend,
// same thread count). Ctrl-C (SIGINT) leaves a valid checkpoint and exits 130 with a message.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "pipeline/flow/checkpoint_io.h"
#include "pipeline/scene.h"
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
  for (const auto& e : fs::directory_iterator(out))  // temporaries are .NAME.PID.partial
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();

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
  // A copy whose saved region record is not JSON: refused naming the checkpoint and the entry,
  // not an internal error.
  const fs::path damaged = *dir_ / "damaged";
  fs::copy(out, damaged, fs::copy_options::recursive);
  {
    namespace mp = mesorock::pipeline;
    const mp::Scene scene = mp::load_scene(scene_);
    mp::ResumePoint point = mp::read_run_checkpoint(damaged / "checkpoint.h5", scene);
    ASSERT_TRUE(point.record.has_text("regions.last"));
    point.record.texts["regions.last"] = "[{\"lower\": ";
    mp::write_run_checkpoint(damaged / "checkpoint.h5", point.state, scene, "{}", point.record);
  }
  const CommandResult broken =
      mesorock::test::run_command(rockflow_run(scene_, damaged, " --resume"), dir_->path());
  EXPECT_EQ(broken.exit_code, 2) << broken.err;
  EXPECT_NE(broken.err.find("checkpoint.h5: /run/text/regions.last"), std::string::npos)
      << broken.err;

  // A step past the scene's end (issue 58: 10^12 resumed to "done" with 63 of 200 rows), and a
  // step the saved thermo rows do not reach: refused naming the checkpoint and the dataset.
  for (const auto& [name, step, dataset] :
       {std::tuple<const char*, std::uint64_t, const char*>{"past_end", 1000000000000ull,
                                                            "/checkpoint/step"},
        {"ahead_of_rows", checkpoint.state.step + 50, "/run/text/thermo.csv"}}) {
    const fs::path copy = *dir_ / name;
    fs::copy(out, copy, fs::copy_options::recursive);
    namespace mp = mesorock::pipeline;
    const mp::Scene scene = mp::load_scene(scene_);
    mp::ResumePoint point = mp::read_run_checkpoint(copy / "checkpoint.h5", scene);
    point.state.step = step;
    mp::write_run_checkpoint(copy / "checkpoint.h5", point.state, scene, "{}", point.record);
    const CommandResult refused =
        mesorock::test::run_command(rockflow_run(scene_, copy, " --resume"), dir_->path());
    EXPECT_EQ(refused.exit_code, 2) << name << ": " << refused.err;
    EXPECT_NE(refused.err.find("checkpoint.h5: " + std::string(dataset)), std::string::npos)
        << name << ": " << refused.err;
    EXPECT_FALSE(fs::exists(copy / "final.h5")) << name;
  }

  const CommandResult r =
      mesorock::test::run_command(rockflow_run(scene_, out, " --resume"), dir_->path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_run(*dir_ / "whole", out);
}

// The mean of a thermo.csv column over the rows after `from_step`.
double mean_after(const fs::path& thermo, std::uint64_t from_step, int column) {
  std::istringstream in(mesorock::test::read_file(thermo));
  std::string line;
  double sum = 0;
  int n = 0;
  while (std::getline(in, line)) {
    if (line.empty() || !std::isdigit(static_cast<unsigned char>(line[0]))) continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    for (std::string c; std::getline(row, c, ',');) cells.push_back(c);
    if (std::stoull(cells.at(0)) <= from_step) continue;
    sum += std::stod(cells.at(static_cast<size_t>(column)));
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

// mpirun -np 2: a decomposed run writes periodic checkpoints (every rank's particles gathered,
// rank 0 writes). A copy of its first one, taken while it runs (the file is replaced by rename, so
// a copy is always whole), resumes on two ranks and on one. Decomposed runs are not bit for bit
// (the order of the force sums differs), so each resumed run must end at the uninterrupted
// decomposed run's step and time with the same particles (ids, types), as many thermo rows, no
// checkpoint left, and a mean temperature after the checkpoint within 5% of that run's
// (thermostat at kBT = 1; means over ~10 rows of ~500 particles scatter by about 1%).
TEST_F(Resume, DecomposedRunCheckpointsAndResumesOnTwoRanksOrOne) {
#if !defined(MESOROCK_MPIEXEC)
  GTEST_SKIP() << "this build has no MPI";
#else
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  setenv("OMP_NUM_THREADS", "1", 1);
  const std::string mpirun = MESOROCK_MPIEXEC;
  const fs::path out = *dir_ / "decomposed", on_two = *dir_ / "on_two", on_one = *dir_ / "on_one";
  fs::create_directories(on_two);
  fs::create_directories(on_one);
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open((*dir_ / "decomposed.err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) dup2(fd, 2);
    const std::string exe = MESOROCK_ROCKFLOW, scene = scene_.string(), o = out.string();
    execl(mpirun.c_str(), mpirun.c_str(), "-np", "2", "--oversubscribe", exe.c_str(), "run",
          scene.c_str(), "--out", o.c_str(), "--threads", "1", "--checkpoint-every", "100",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  bool copied = false;
  int status = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(300)) {
    if (waitpid(pid, &status, WNOHANG) == pid) break;
    std::error_code ec;
    if (!copied && fs::copy_file(out / "checkpoint.h5", on_two / "checkpoint.h5", ec)) {
      fs::copy_file(on_two / "checkpoint.h5", on_one / "checkpoint.h5");
      copied = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!WIFEXITED(status)) {  // still running after 300 s: end it
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  const std::string err = mesorock::test::read_file(*dir_ / "decomposed.err");
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << err;
  ASSERT_TRUE(copied) << "the run ended before its first checkpoint could be copied";
  EXPECT_FALSE(fs::exists(out / "checkpoint.h5")) << "a completed run removes its checkpoint";
  const auto checkpoint = mesorock::sim::read_checkpoint(on_two / "checkpoint.h5");
  ASSERT_GT(checkpoint.state.step, 0u);
  EXPECT_EQ(checkpoint.state.step % 100, 0u);
  EXPECT_EQ(checkpoint.scene_text, kScene);

  const CommandResult two = mesorock::test::run_command(
      mesorock::test::shell_quote(mpirun) + " -np 2 --oversubscribe " +
          mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
          mesorock::test::shell_quote(scene_.string()) + " --out " +
          mesorock::test::shell_quote(on_two.string()) + " --threads 1 --resume",
      dir_->path());
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_NE(two.err.find("resumed at step"), std::string::npos) << two.err;
  const CommandResult one =
      mesorock::test::run_command(rockflow_run(scene_, on_one, " --resume"), dir_->path());
  ASSERT_EQ(one.exit_code, 0) << one.err;

  mesorock::sim::ParticleFileMeta mu;
  const auto uninterrupted = mesorock::sim::read_particle_file(out / "final.h5", &mu);
  const double T_ref = mean_after(out / "thermo.csv", checkpoint.state.step, 3);
  const auto rows = [](const fs::path& f) {
    const std::string t = mesorock::test::read_file(f);
    return std::count(t.begin(), t.end(), '\n');
  };
  for (const fs::path& run : {on_two, on_one}) {
    mesorock::sim::ParticleFileMeta m;
    const auto p = mesorock::sim::read_particle_file(run / "final.h5", &m);
    EXPECT_EQ(m.step, mu.step) << run;
    EXPECT_EQ(m.time, mu.time) << run;
    EXPECT_EQ(p.id, uninterrupted.id) << run;
    EXPECT_EQ(p.type, uninterrupted.type) << run;
    EXPECT_EQ(rows(run / "thermo.csv"), rows(out / "thermo.csv")) << run;
    EXPECT_FALSE(fs::exists(run / "checkpoint.h5")) << run;
    const double T = mean_after(run / "thermo.csv", checkpoint.state.step, 3);
    EXPECT_NEAR(T, T_ref, 0.05 * T_ref) << run;
  }
#endif
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

// Issue 58, item 11: a particle file the scene names, replaced between the interrupt and the
// resume, was loaded silently (the scene's text was the same). Its checksum is in the checkpoint:
// the resume is refused naming the file; the file as it was resumes.
TEST(ResumeCli, AChangedFileOfTheSceneIsRefused) {
  namespace ms = mesorock::sim;
  TempDir dir;
  ms::ParticleSet p;
  std::int64_t next = 0;
  for (int k = 0; k < 300; ++k) {
    p.x.push_back(0.1 + 3.8 * ((k * 37) % 300) / 300.0);
    p.y.push_back(0.1 + 3.8 * ((k * 91) % 300) / 300.0);
    p.z.push_back(0.1 + 3.8 * k / 300.0);
    p.vx.push_back(0), p.vy.push_back(0), p.vz.push_back(0);
    p.type.push_back(0);
    p.id.push_back(next++);
  }
  ms::ParticleFileMeta meta;
  meta.type_names = {"water"};
  meta.box.hi = {4, 4, 4};
  ms::write_particle_file(dir / "particles.h5", p, meta);
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene)
      << "name = \"files\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [4.0, 4.0, 4.0]\n"
         "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
         "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
         "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"water\"\n"
         "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
         "[[init]]\nkind = \"file\"\nfile = \"particles.h5\"\n"
         "[[run]]\nsteps = 200000\ndt = 0.01\n[output]\nthermo_every = 10\n";
  const fs::path out = dir / "out";
  bool was_running = false;
  const int status = run_and_signal(scene, out, dir / "int.err", SIGINT, &was_running);
  ASSERT_TRUE(was_running) << mesorock::test::read_file(dir / "int.err");
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130)
      << mesorock::test::read_file(dir / "int.err");
  fs::copy_file(dir / "particles.h5", dir / "kept.h5");
  p.vx[7] = 0.5;  // another file at the same path
  ms::write_particle_file(dir / "particles.h5", p, meta);
  const std::string resume = mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " run " +
                             mesorock::test::shell_quote(scene.string()) + " --out " +
                             mesorock::test::shell_quote(out.string()) + " --threads 1 --resume";
  const CommandResult changed = mesorock::test::run_command(resume, dir.path());
  EXPECT_EQ(changed.exit_code, 2) << changed.err;
  EXPECT_NE(changed.err.find("particles.h5 has changed since the checkpoint"), std::string::npos)
      << changed.err;
  EXPECT_NE(changed.err.find("checkpoint.h5"), std::string::npos) << changed.err;
  fs::rename(dir / "kept.h5", dir / "particles.h5");
  // Back as it was: the resume passes the check (it is stopped again after its next checkpoint;
  // the run is long on purpose).
  const CommandResult same = mesorock::test::run_command(
      "timeout --preserve-status -s INT 2 " + resume + " --checkpoint-every 10", dir.path());
  EXPECT_EQ(same.exit_code, 130) << same.err;
  EXPECT_NE(same.err.find("resumed at step"), std::string::npos) << same.err;
}

}  // namespace
