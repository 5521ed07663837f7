// Input guards of rockflow (issue 22, items 2 and 9): a run that cannot fit in memory is refused
// before any particle is made, naming the key and the bytes; Ctrl-C during set-up acts between
// the set-up passes; errors name the file they are about (a sweep without a driven type, a
// checkpoint holding NaN).
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "mesorock/errors.h"
#include "pipeline/flow/checkpoint_io.h"
#include "pipeline/scene.h"
#include "sim/checkpoint.h"
#include "sim/memory_budget.h"
#include "sim/simulation.h"
#include "sim/solid_grid.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

namespace {

// A periodic mDPD box with `init` as its [[init]] blocks.
std::string scene_with(const std::string& init, double edge = 10) {
  const std::string e = std::to_string(edge);
  return "name = \"guard\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [" + e + ", " + e + ", " +
         e +
         "]\nboundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
         "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
         "thermostat = true\nkBT = 1.0\n"
         "[[types]]\nname = \"water\"\n"
         "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n" +
         init + "[[run]]\nsteps = 10\ndt = 0.01\n[output]\nthermo_every = 5\n";
}

std::string random_block(const std::string& count) {
  return "[[init]]\nkind = \"random\"\ntype = \"water\"\ncount = " + count + "\n";
}

fs::path write_scene(const TempDir& dir, const std::string& text) {
  const fs::path p = dir / "scene.toml";
  std::ofstream(p) << text;
  return p;
}

struct Timed {
  CommandResult r;
  double seconds = 0;
};

// rockflow with `args` in `dir`, under a cap on its address space (ulimit -v, KiB): the code before
// the guard allocated until the kernel stopped it; the cap keeps such a failure quick and harmless.
Timed rockflow_capped(const std::string& args, const TempDir& dir, long cap_kib = 16000000) {
  const auto t0 = std::chrono::steady_clock::now();
  Timed t;
  t.r = mesorock::test::run_command("cd " + shell_quote(dir.path().string()) + " && ulimit -v " +
                                        std::to_string(cap_kib) + " && " +
                                        shell_quote(MESOROCK_ROCKFLOW) + " " + args,
                                    dir.path());
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return t;
}

void expect_refused(const Timed& t, const std::string& key) {
  EXPECT_EQ(t.r.exit_code, 2) << t.r.err;
  EXPECT_NE(t.r.err.find(key), std::string::npos) << "names no " << key << ": " << t.r.err;
  EXPECT_NE(t.r.err.find("bytes"), std::string::npos) << t.r.err;
  EXPECT_NE(t.r.err.find("GiB"), std::string::npos) << t.r.err;
  // Before any particle is made (measured: ~0.05 s); the bound is generous on purpose.
  EXPECT_LT(t.seconds, 5.0) << t.r.err;
}

TEST(MemoryGuard, AHugeInitCountIsRefusedBeforeAnyParticle) {
  TempDir dir;
  const fs::path scene = write_scene(dir, scene_with(random_block("2147483647")));
  const Timed t = rockflow_capped("run " + shell_quote(scene.string()) + " --out out", dir);
  expect_refused(t, "init[0].count");
  EXPECT_NE(t.r.err.find("host memory"), std::string::npos) << t.r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// Issue 58, item 2: 200,000 particles in a 5^3 box (rho = 1600) passed the guard's 406 bytes a
// particle, which assume about 15 neighbour pairs each; the half list grew past 10 GB and the
// process aborted on std::bad_alloc (exit 134) after 18 s under a 4 GB cap. The list is sized
// from the density now: refused before any particle.
TEST(MemoryGuard, ADenseBoxIsRefusedBeforeAnyParticleUnderACap) {
  TempDir dir;
  const fs::path scene = write_scene(dir, scene_with(random_block("200000"), 5));
  const Timed t = rockflow_capped("run " + shell_quote(scene.string()) + " --out out --threads 1",
                                  dir, 4000000);
  expect_refused(t, "init[0].count");
  EXPECT_NE(t.r.err.find("host memory"), std::string::npos) << t.r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(MemoryGuard, BlocksWithinTheLimitEachButNotTogetherAreRefused) {
  TempDir dir;
  const fs::path scene =
      write_scene(dir, scene_with(random_block("2000000000") + random_block("2000000000")));
  const Timed t = rockflow_capped("run " + shell_quote(scene.string()) + " --out out", dir);
  expect_refused(t, "[[init]] blocks: total 4000000000");
  // sweep reads the same scene the same way.
  const Timed s = rockflow_capped(
      "sweep " + shell_quote(scene.string()) + " --forces 0.01 --fluid-density 3 --out sw", dir);
  expect_refused(s, "[[init]] blocks: total 4000000000");
}

TEST(MemoryGuard, BenchRefusesParticlesBeyondMemory) {
  TempDir dir;
  const Timed t = rockflow_capped("bench --particles 2000000000 --steps 1", dir);
  expect_refused(t, "--particles 2000000000");
}

// Under `ulimit -v` the limit is the address space left: 2e7 particles (5.5 GB) under a 2 GiB cap
// used to fail with exit 1 and "out of memory", naming nothing.
TEST(MemoryGuard, AnAddressSpaceLimitIsNamed) {
  TempDir dir;
  const fs::path scene = write_scene(dir, scene_with(random_block("20000000"), 100));
  const Timed t =
      rockflow_capped("run " + shell_quote(scene.string()) + " --out out", dir, 2 * 1024 * 1024);
  expect_refused(t, "init[0].count");
  EXPECT_NE(t.r.err.find("RLIMIT_AS"), std::string::npos) << t.r.err;
}

// The estimate must not refuse normal runs: 16 M particles fit a 128 GiB machine with room to
// spare, in either precision, on either backend's budget.
TEST(MemoryGuard, SixteenMillionParticlesFitA128GiBMachine) {
  namespace ms = mesorock::sim;
  ms::MemoryAvailable machine;
  machine.bytes = 128.0 * 1024 * 1024 * 1024;
  machine.source = "test";
  for (ms::Precision p : {ms::Precision::Single, ms::Precision::Double}) {
    const double cells = 16e6 / 3;  // the sparsest fluid packs 3 particles per rc^3
    EXPECT_EQ(
        ms::memory_shortfall(16e6 * ms::host_bytes_per_particle(p) + cells * ms::kHostBytesPerCell,
                             machine, "host"),
        "");
    EXPECT_EQ(ms::memory_shortfall(
                  16e6 * ms::device_bytes_per_particle(p) + cells * ms::kDeviceBytesPerCell,
                  machine, "device"),
              "");
    EXPECT_NE(ms::memory_shortfall(2147483647.0 * ms::host_bytes_per_particle(p), machine, "host"),
              "");
  }
  // This machine's budget is readable, and a small scene passes it.
  EXPECT_TRUE(ms::host_memory_available().bytes.has_value());
  TempDir dir;
  const mesorock::pipeline::Scene s =
      mesorock::pipeline::load_scene(write_scene(dir, scene_with(random_block("3000"))));
  EXPECT_NO_THROW(mesorock::pipeline::check_memory_for(s, {}));
}

// Ctrl-C during the set-up of a large run (1 M particles, one thread: seconds of set-up) stops it
// between set-up passes, writes nothing and exits 130; it used to finish the set-up and the first
// steps, then write a checkpoint (37 s for 4 M particles on 2 cores).
TEST(SetupInterrupt, CtrlCDuringSetUpStopsBeforeAnyStep) {
  TempDir dir;
  const fs::path scene =
      write_scene(dir,
                  "name = \"big\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [52.0, 52.0, 52.0]\n"
                  "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
                  "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
                  "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"water\"\n"
                  "[[pairs]]\ntypes = [\"water\", \"water\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
                  "[[init]]\nkind = \"random\"\ntype = \"water\"\ndensity = 7.0\n"
                  "[[run]]\nsteps = 1000\ndt = 0.01\n[output]\nthermo_every = 100\n");
  // The signal goes 0.5 s after the start: past the scene's parse (the handler is installed),
  // well inside the set-up. The shell reports the time from the signal to the exit.
  const std::string cmd = "(cd " + shell_quote(dir.path().string()) + "; " +
                          shell_quote(MESOROCK_ROCKFLOW) + " run " + shell_quote(scene.string()) +
                          " --out out --threads 1 & pid=$!; sleep 0.5; " +
                          "t0=$(date +%s%N); kill -INT $pid; wait $pid; rc=$?; " +
                          "echo latency_ms=$(( ($(date +%s%N) - t0) / 1000000 )) >&2; exit $rc)";
  const CommandResult r = mesorock::test::run_command(cmd, dir.path());
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_NE(r.err.find("Ctrl-C during set-up"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nothing was written"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "checkpoint.h5")) << r.err;
  std::cerr << r.err;  // the latency, for the record
}

// `rockflow sweep` of a scene whose every type is frozen: "sweep: no driven type" named no file.
TEST(ErrorsNameTheFile, SweepWithoutADrivenType) {
  TempDir dir;
  const fs::path scene =
      write_scene(dir,
                  "name = \"frozen\"\nseed = 1\n[box]\nlo = [0.0, 0.0, 0.0]\nhi = [4.0, 4.0, 4.0]\n"
                  "boundary = [\"periodic\", \"periodic\", \"periodic\"]\n"
                  "[model]\nconservative = \"mdpd\"\ndensity_kernel = \"warren\"\nrd = 0.75\n"
                  "thermostat = true\nkBT = 1.0\n[[types]]\nname = \"wall\"\nfrozen = true\n"
                  "[[pairs]]\ntypes = [\"wall\", \"wall\"]\nA = -40.0\nB = 25.0\ngamma = 4.5\n"
                  "[[init]]\nkind = \"lattice\"\ntype = \"wall\"\ndensity = 3.0\n"
                  "[[run]]\nsteps = 10\ndt = 0.01\n");
  const CommandResult r = mesorock::test::run_command(
      "cd " + shell_quote(dir.path().string()) + " && " + shell_quote(MESOROCK_ROCKFLOW) +
          " sweep " + shell_quote(scene.string()) +
          " --forces 0.01 --fluid-density 3 --viscosity 1 --out sw --threads 1",
      dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("no driven type"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(scene.string()), std::string::npos) << r.err;
}

// A checkpoint whose positions hold a NaN: the solver's input check said "particle N has a
// non-finite position or velocity", naming no file.
TEST(ErrorsNameTheFile, CheckpointHoldingNaN) {
  namespace ms = mesorock::sim;
  TempDir dir;
  const fs::path scene_path = write_scene(dir, scene_with(random_block("300"), 4));
  const mesorock::pipeline::Scene scene = mesorock::pipeline::load_scene(scene_path);
  auto sim = ms::make_simulation(scene.model, scene.box,
                                 mesorock::pipeline::build_initial_particles(scene), 0.01, {});
  ms::CheckpointFile c;
  c.state = sim->state();
  c.state.x[7] = std::numeric_limits<double>::quiet_NaN();
  c.created_by = "rockflow run";
  c.scene_path = scene_path.string();
  c.scene_text = scene.source_text;
  fs::create_directories(dir / "out");
  const fs::path checkpoint = dir / "out" / "checkpoint.h5";
  ms::write_checkpoint(checkpoint, c);
  const CommandResult r = mesorock::test::run_command(
      "cd " + shell_quote(dir.path().string()) + " && " + shell_quote(MESOROCK_ROCKFLOW) + " run " +
          shell_quote(scene_path.string()) + " --out out --resume --threads 1",
      dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("out/checkpoint.h5: /checkpoint/x"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("NaN"), std::string::npos) << r.err;
}

// Issue 58, item 14: two errors of the solver's input check named no file. A fluid particle of
// the scene inside a solid voxel names the scene; a particle type out of range in a checkpoint
// names the checkpoint.
TEST(ErrorsNameTheFile, AParticleInTheSolidNamesTheScene) {
  namespace ms = mesorock::sim;
  TempDir dir;
  ms::SolidMask mask;
  mask.dims = {4, 4, 4};
  mask.solid.assign(64, 0);
  for (int k = 0; k < 16; ++k) mask.solid[static_cast<std::size_t>(k)] = 1;  // the z < 1 layer
  ms::write_solid_file(dir / "solid.h5", mask, "test", "{}");
  std::string text = scene_with(random_block("300"), 4);
  text += "[solid]\nfile = \"solid.h5\"\n";
  const fs::path scene = write_scene(dir, text);
  const CommandResult r = mesorock::test::run_command(
      "cd " + shell_quote(dir.path().string()) + " && " + shell_quote(MESOROCK_ROCKFLOW) + " run " +
          shell_quote(scene.string()) + " --out out --threads 1",
      dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(scene.string() + ": particle "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("starts inside a solid voxel"), std::string::npos) << r.err;
}

TEST(ErrorsNameTheFile, ACheckpointParticleOfAnUnknownTypeNamesTheCheckpoint) {
  namespace ms = mesorock::sim;
  namespace mp = mesorock::pipeline;
  TempDir dir;
  const fs::path scene_path = write_scene(dir, scene_with(random_block("300"), 4));
  const mp::Scene scene = mp::load_scene(scene_path);
  auto sim =
      ms::make_simulation(scene.model, scene.box, mp::build_initial_particles(scene), 0.01, {});
  ms::SimulationState state = sim->state();
  state.type[11] = 65536;
  fs::create_directories(dir / "out");
  mp::RunRecord record;
  record.numbers["time"] = {0.0};
  record.numbers["run_seconds"] = {0.0};
  mp::write_run_checkpoint(dir / "out" / "checkpoint.h5", state, scene, "{}", record);
  const CommandResult r = mesorock::test::run_command(
      "cd " + shell_quote(dir.path().string()) + " && " + shell_quote(MESOROCK_ROCKFLOW) + " run " +
          shell_quote(scene_path.string()) + " --out out --resume --threads 1",
      dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("out/checkpoint.h5 (of "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("type 65536"), std::string::npos) << r.err;
}

}  // namespace
