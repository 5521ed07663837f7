// Two runs started on one output folder (issue 58, item 1). Before the output lock, `rockflow run
// A --out D` and, a second later, `rockflow run B --out D` shared `.thermo.csv.partial`: A ended
// with exit 0 "done" over a thermo.csv holding B's header and rows and a fragment of its own. Now
// the second is refused at once (exit 2, naming the folder and the first's pid), and the first's
// outputs are byte for byte those of a run alone (summary.json less its timings; final.h5's
// particles bit for bit, since HDF5 records the times its objects were written).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "mesorock/output_lock.h"
#include "sim/particle_io.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

namespace {

// A periodic mDPD liquid of about 1,400 particles for 1,500 steps: a few seconds on one thread.
std::string scene(int seed) {
  return "name = \"concurrent\"\nseed = " + std::to_string(seed) +
         "\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [6.0, 6.0, 6.0]\n"
         "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
         "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
         "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"water\"\n"
         "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
         "[[init]]\nkind = \"random\"\ntype = \"water\"\ndensity = 6.5\n"
         "[[run]]\nsteps = 1500\ndt = 0.01\n[output]\nthermo_every = 50\n";
}

std::string rockflow_run(const fs::path& scene_file, const fs::path& out) {
  return shell_quote(MESOROCK_ROCKFLOW) + " run " + shell_quote(scene_file.string()) + " --out " +
         shell_quote(out.string()) + " --threads 1";
}

std::set<std::string> files_in(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    names.insert(fs::relative(e.path(), dir).string());
  return names;
}

nlohmann::json without_timings(nlohmann::json summary) {
  for (const char* k : {"wall_seconds", "run_seconds", "mps", "mobile_mps", "time_split"})
    summary.erase(k);
  return summary;
}

TEST(ConcurrentRuns, ASecondRunOnOneFolderIsRefusedAtOnceAndTheFirstIsAsIfAlone) {
  TempDir dir;
  const fs::path a = dir / "a.toml", b = dir / "b.toml", out = dir / "D", alone = dir / "alone";
  std::ofstream(a) << scene(1);
  std::ofstream(b) << scene(2);
  const fs::path first_err = dir / "first.err";
  const pid_t first = fork();
  if (first == 0) {
    const int fd = open(first_err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) dup2(fd, 2);
    const std::string exe = MESOROCK_ROCKFLOW;
    execl(exe.c_str(), exe.c_str(), "run", a.c_str(), "--out", out.c_str(), "--threads", "1",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // The first run holds the folder once its lock file exists; the second starts while it steps.
  const auto t0 = std::chrono::steady_clock::now();
  int status = 0;
  bool ended = false;
  while (!fs::exists(out / mesorock::OutputLock::kFileName) &&
         std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
    if (waitpid(first, &status, WNOHANG) == first) {
      ended = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_FALSE(ended) << "the first run ended before the second could start: "
                      << mesorock::test::read_file(first_err);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto t1 = std::chrono::steady_clock::now();
  const CommandResult second = mesorock::test::run_command(rockflow_run(b, out), dir.path());
  const double refused_in =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  waitpid(first, &status, 0);
  EXPECT_EQ(second.exit_code, 2) << second.err;
  EXPECT_LT(refused_in, 1.0) << second.err;
  EXPECT_NE(
      second.err.find(out.string() + ": in use by another process (pid " + std::to_string(first)),
      std::string::npos)
      << second.err;
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << mesorock::test::read_file(first_err);

  const CommandResult lone = mesorock::test::run_command(rockflow_run(a, alone), dir.path());
  ASSERT_EQ(lone.exit_code, 0) << lone.err;
  ASSERT_EQ(files_in(out), files_in(alone));
  for (const std::string& f : files_in(out)) {
    if (fs::is_directory(out / f)) continue;
    const std::string x = mesorock::test::read_file(out / f),
                      y = mesorock::test::read_file(alone / f);
    if (f == "final.h5") {  // HDF5 records object times: the particles, bit for bit
      mesorock::sim::ParticleFileMeta ma, mb;
      const auto pa = mesorock::sim::read_particle_file(out / f, &ma);
      const auto pb = mesorock::sim::read_particle_file(alone / f, &mb);
      for (const auto& [u, v] : {std::pair{&pa.x, &pb.x},
                                 {&pa.y, &pb.y},
                                 {&pa.z, &pb.z},
                                 {&pa.vx, &pb.vx},
                                 {&pa.vy, &pb.vy},
                                 {&pa.vz, &pb.vz}})
        EXPECT_TRUE(*u == *v) << "final.h5 differs from a run alone";
      EXPECT_EQ(pa.id, pb.id);
      EXPECT_EQ(ma.step, mb.step);
    } else if (f == "summary.json")
      EXPECT_EQ(without_timings(nlohmann::json::parse(x)),
                without_timings(nlohmann::json::parse(y)));
    else
      EXPECT_TRUE(x == y) << f << " differs from a run alone";
  }
}

}  // namespace
