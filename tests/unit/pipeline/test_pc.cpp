// `rockflow pc`: primary drainage on a tiny flooding set-up (a slit in a block between an N
// reservoir and a W reservoir, each held by a slab), its outputs, the membrane, and bad input.
// The entry pressure against Young-Laplace is the drainage-slit validation case.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <tuple>

#include "pipeline/flow/drainage.h"
#include "sim/particle_io.h"
#include "support/test_support.h"
#include "unit/pipeline/tiny_slit.h"

namespace fs = std::filesystem;
namespace mp = mesorock::pipeline;
namespace ms = mesorock::sim;
using mesorock::test::CommandResult;
using mesorock::test::TempDir;

namespace {

// Along x: the pushing slab [-1, 0), working fluid (N) [0, 4), the block [4, 10) with a wall
// 1.5 rc thick under a slit 3.5 rc wide (periodic z) holding the source fluid (W), source fluid
// [10, 14), the back slab [14, 15), room up to 20. About 1,700 particles. The slabs and the wall
// exert nothing on each other (they never meet).
constexpr const char* kTinyFlooding = R"(name = "tiny-flooding"
seed = 11
[box]
lo = [-1.5, 0.0, 0.0]
hi = [20.0, 3.0, 5.0]
boundary = ["reflective", "periodic", "periodic"]
[model]
conservative = "mdpd"
[[types]]
name = "source"
[[types]]
name = "working"
[[types]]
name = "wall"
frozen = true
[[types]]
name = "push_slab"
[[types]]
name = "back_slab"
[[pairs]]
types = ["source", "source"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "working"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "working"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "wall"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "wall"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "push_slab"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["source", "back_slab"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "push_slab"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["working", "back_slab"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["wall", "wall"]
A = 0.0
B = 0.0
gamma = 0.0
[[pairs]]
types = ["wall", "push_slab"]
A = 0.0
B = 0.0
gamma = 0.0
[[pairs]]
types = ["wall", "back_slab"]
A = 0.0
B = 0.0
gamma = 0.0
[[pairs]]
types = ["push_slab", "push_slab"]
A = 0.0
B = 0.0
gamma = 0.0
[[pairs]]
types = ["push_slab", "back_slab"]
A = 0.0
B = 0.0
gamma = 0.0
[[pairs]]
types = ["back_slab", "back_slab"]
A = 0.0
B = 0.0
gamma = 0.0
[walls]
model = "li2018"
types = ["wall"]
[[virtual_walls]]
axis = "x"
position = 4.0
types = ["working"]
keep = "below"
until_step = 200
[[virtual_walls]]
axis = "x"
position = 4.0
types = ["source"]
keep = "above"
until_step = 200
[[slabs]]
type = "push_slab"
axis = "x"
pressure = 60.0
[[slabs]]
type = "back_slab"
axis = "x"
pressure = -60.0
[[init]]
kind = "lattice"
type = "push_slab"
density = 8.0
lo = [-1.0, 0.0, 0.0]
hi = [0.0, 3.0, 5.0]
[[init]]
kind = "random"
type = "working"
density = 7.0
lo = [0.0, 0.0, 0.0]
hi = [4.0, 3.0, 5.0]
[[init]]
kind = "lattice"
type = "wall"
density = 8.0
lo = [4.0, 0.0, 0.0]
hi = [10.0, 3.0, 1.5]
[[init]]
kind = "random"
type = "source"
density = 7.0
lo = [4.0, 0.0, 1.5]
hi = [10.0, 3.0, 5.0]
[[init]]
kind = "random"
type = "source"
density = 7.0
lo = [10.0, 0.0, 0.0]
hi = [14.0, 3.0, 5.0]
[[init]]
kind = "lattice"
type = "back_slab"
density = 8.0
lo = [14.0, 0.0, 0.0]
hi = [15.0, 3.0, 5.0]
[[run]]
name = "relax"
steps = 200
dt = 0.002
[[run]]
name = "flood"
steps = 100
dt = 0.01
[[output.regions]]
name = "block"
lo = [4.0, 0.0, 0.0]
hi = [10.0, 3.0, 5.0]
types = ["source", "working"]
saturation_of = "source"
[units]
nm_per_rc = 0.852
)";

std::string rockflow_pc(const fs::path& scene, const fs::path& out) {
  return mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " pc " +
         mesorock::test::shell_quote(scene.string()) + " --out " +
         mesorock::test::shell_quote(out.string()) + " ";
}

// At Pc = 0 (neutral wetting: no entry pressure, nothing pushes) N stays out of the block; at
// Pc = 20 it flows into the slit, W leaves through the outlet (the back slab moves out), and the
// membrane keeps N in the block.
TEST(PcCommand, DrainsTheSlitUnderPressureAndKeepsNBehindTheMembrane) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene) << kTinyFlooding;
  const CommandResult r =
      mesorock::test::run_command(rockflow_pc(scene, dir / "out") +
                                      "--pressures 0,20 --ramp-steps 100 --block-steps 100 "
                                      "--sample-every 20 --window 1 --measure-blocks 3 "
                                      "--tolerance 0.02 --max-level-steps 700 --threads 2",
                                  dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("primary drainage"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(mesorock::test::read_file(dir / "out" / "pc.json"));
  EXPECT_EQ(j.at("back_pressure").get<double>(), 60.0);
  EXPECT_EQ(j.at("phases").at("A_WN").get<double>(), -30.0);
  EXPECT_EQ(j.at("phases").at("walls").at("wall").at("A_SN").get<double>(), -40.0);
  const auto& levels = j.at("levels");
  ASSERT_EQ(levels.size(), 2u);
  const double s0 = levels[0].at("S_w").at("value").get<double>();
  const double s1 = levels[1].at("S_w").at("value").get<double>();
  EXPECT_GT(s0, 0.9);  // neutral wetting: N creeps in a little even at Pc = 0
  EXPECT_LT(s1, s0 - 0.15);
  EXPECT_GT(levels[1].at("back_position").get<double>(),
            levels[0].at("back_position").get<double>() + 0.3);
  EXPECT_TRUE(levels[1].contains("Pc_Pa"));
  for (const auto& l : levels) EXPECT_EQ(l.at("fluid_behind_slabs").get<int>(), 0);
  EXPECT_TRUE(j.at("entry").at("found").get<bool>());
  EXPECT_EQ(j.at("entry").at("upper").get<double>(), 20.0);
  for (const char* f :
       {"pc.csv", "pc_blocks.csv", "pc.png", "states/level_0.h5", "states/level_1.xmf"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "out" / "pc.partial.csv"));  // removed once the outputs are in
  ms::ParticleFileMeta meta;
  const ms::ParticleSet end = ms::read_particle_file(dir / "out" / "states" / "level_1.h5", &meta);
  ASSERT_EQ(meta.type_names[1], "working");
  std::size_t n_in_block = 0, n_beyond = 0;
  for (size_t i = 0; i < end.size(); ++i)
    if (end.type[i] == 1) {
      n_in_block += end.x[i] >= 4 && end.x[i] < 10;
      n_beyond += end.x[i] >= 10;
    }
  EXPECT_EQ(n_beyond, 0u);
  EXPECT_EQ(n_in_block, levels[1].at("N_in_block").get<std::size_t>());
}

// A run stopped from outside (a batch system's time limit) keeps the levels it finished in
// pc.partial.csv, and writes none of the final outputs.
TEST(PcCommand, KeepsTheFinishedLevelsWhenStoppedFromOutside) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml";
  std::ofstream(scene) << kTinyFlooding;
  const std::string pc = rockflow_pc(scene, dir / "out") +
                         "--pressures 0,20,25 --ramp-steps 100 --block-steps 100 "
                         "--sample-every 20 --window 1 --measure-blocks 3 --tolerance 0.02 "
                         "--max-level-steps 5000 --threads 1";
  const fs::path partial = dir / "out" / "pc.partial.csv";
  const std::string q = mesorock::test::shell_quote(partial.string());
  const CommandResult r =
      mesorock::test::run_command("(" + pc + " & pid=$!; for i in $(seq 3000); do [ -f " + q +
                                      " ] && break; sleep 0.1; done; kill $pid; wait $pid; true)",
                                  dir.path());
  ASSERT_TRUE(fs::exists(partial)) << r.err;
  const std::string text = mesorock::test::read_file(partial);
  EXPECT_EQ(text.rfind("# partial", 0), 0u) << text;
  EXPECT_NE(text.find("\n0,drainage,0,"), std::string::npos) << text;
  EXPECT_EQ(text.find("\n2,drainage,"), std::string::npos) << text;
  for (const char* f : {"pc.csv", "pc.json", "pc.png"})
    EXPECT_FALSE(fs::exists(dir / "out" / f)) << f;
}

// Bad input: one line naming the problem, before any step and any output.
TEST(PcCommand, RefusesBadInputBeforeAnyStep) {
  TempDir dir;
  const fs::path scene = dir / "scene.toml", slit = dir / "slit.toml";
  std::ofstream(scene) << kTinyFlooding;
  std::ofstream(slit) << mesorock::test::kTinySlit;
  const std::vector<std::tuple<fs::path, std::string, std::string>> refused = {
      {scene, "--pressures 0,2,1", "must rise from level to level"},
      {scene, "--pressures -1,2", "finite and >= 0"},
      {scene, "--pressures 0,2 --imbibition 1,3", "must fall from the last drainage level"},
      {scene, "--pressures 0,1 --wetting oil", "no type oil"},
      {scene, "--pressures 0,1 --nonwetting wall", "does not flow"},
      {scene, "--pressures 0,1 --cross-A -45", "less attractive than the fluid's own"},
      {scene, "--pressures 0,1 --measure-blocks 2", "at least 3 measured blocks"},
      {scene, "--pressures 0,1 --block-steps 100 --max-level-steps 300", "no room for the steady"},
      {slit, "--pressures 0,1", "needs a pushing slab and a back-pressure slab"}};
  for (const auto& [file, args, message] : refused) {
    const CommandResult e =
        mesorock::test::run_command(rockflow_pc(file, dir / "bad") + args, dir.path());
    EXPECT_NE(e.exit_code, 0) << args;
    EXPECT_NE(e.err.find(message), std::string::npos) << args << ": " << e.err;
    EXPECT_EQ(std::count(e.err.begin(), e.err.end(), '\n'), 1) << args << ": " << e.err;
    EXPECT_FALSE(fs::exists(dir / "bad")) << args;
  }
}

mp::DrainageLevel level_at(double pc, double s_w) {
  mp::DrainageLevel l;
  l.pc_applied = pc;
  l.saturation.mean = s_w;
  return l;
}

// The entry bracket: the first level below the threshold and the one before it.
TEST(EntryPressure, BracketsTheFirstInvadedLevel) {
  const std::vector<mp::DrainageLevel> levels{level_at(0, 1.0), level_at(1, 0.97), level_at(2, 0.4),
                                              level_at(3, 0.1)};
  const mp::EntryPressure e = mp::entry_pressure(levels, 0.5);
  ASSERT_TRUE(e.found);
  EXPECT_EQ(e.lower, 1.0);
  EXPECT_EQ(e.upper, 2.0);
  EXPECT_EQ(e.estimate(), 1.5);
  EXPECT_EQ(e.half_width(), 0.5);
  EXPECT_FALSE(mp::entry_pressure(levels, 0.05).found);
  const mp::EntryPressure first = mp::entry_pressure({level_at(0.5, 0.2)}, 0.5);
  EXPECT_EQ(first.lower, 0.0);
  EXPECT_EQ(first.upper, 0.5);
}

}  // namespace
