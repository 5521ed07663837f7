// Scene files: a good scene parses into the expected Model/Box/stages; every bad scene in
// tests/data/scenes/bad/ fails with a one-line "file: key: problem" message (its first line says
// `# expect: <substring>`), both through load_scene and through `rockflow run`; initial
// particles are built reproducibly from random, lattice and HDF5 blocks.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mesorock/errors.h"
#include "pipeline/scene.h"
#include "sim/init.h"
#include "sim/particle_io.h"
#include "sim/solid_grid.h"
#include "support/test_support.h"

namespace fs = std::filesystem;
using mesorock::ConfigError;
using mesorock::IoError;
using mesorock::pipeline::build_initial_particles;
using mesorock::pipeline::InitSpec;
using mesorock::pipeline::load_scene;
using mesorock::pipeline::parse_scene;
using mesorock::pipeline::Scene;
namespace sim = mesorock::sim;

using mesorock::test::read_file;
using mesorock::test::run_command;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

namespace {

const fs::path kScenes = fs::path(MESOROCK_SOURCE_DIR) / "tests" / "data" / "scenes";

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// The message of the mesorock::Error f throws ("<none>" if it throws none).
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const mesorock::Error& e) {
    return e.what();
  }
  return "<none>";
}

// A complete, valid two-type scene; tests append or substitute pieces.
const char* kTwoTypeScene = R"(
seed = 7
[box]
lo = [0.0, 0.0, 0.0]
hi = [8.0, 6.0, 5.0]
[model]
conservative = "mdpd"
[[types]]
name = "fluid"
[[types]]
name = "wall"
frozen = true
[[pairs]]
types = ["fluid", "fluid"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["wall", "fluid"]
A = -30
B = 25
gamma = 4.5
[[pairs]]
types = ["wall", "wall"]
A = 0.0
B = 0.0
gamma = 0.0
[[run]]
steps = 5
dt = 0.01
)";

}  // namespace

// ---------------------------------------------------------------------------------------------
// Good scenes

TEST(Scene, GoodBulkSceneParsesIntoModelBoxAndStages) {
  const fs::path path = kScenes / "good_bulk.toml";
  const Scene s = load_scene(path);
  EXPECT_EQ(s.path, path);
  EXPECT_EQ(s.name, "bulk-mdpd");
  EXPECT_EQ(s.source_text, read_file(path));

  const sim::Model& m = s.model;
  EXPECT_EQ(m.seed, 42u);
  EXPECT_EQ(m.precision, sim::Precision::Double);
  EXPECT_EQ(m.conservative, sim::ConservativeKind::MDPD);
  EXPECT_EQ(m.density_kernel, sim::DensityKernelKind::Warren);
  EXPECT_EQ(m.rd, 0.75);
  EXPECT_TRUE(m.thermostat);
  EXPECT_EQ(m.kBT, 1.0);
  EXPECT_EQ(m.lambda, 0.5);
  ASSERT_EQ(m.ntypes(), 1);
  EXPECT_EQ(m.types[0].name, "fluid");
  EXPECT_FALSE(m.types[0].frozen);
  EXPECT_FALSE(m.has_body_force());
  ASSERT_EQ(m.pairs.size(), 1u);
  EXPECT_EQ(m.pair(0, 0).A, -40.0);
  EXPECT_EQ(m.pair(0, 0).B, 25.0);
  EXPECT_EQ(m.pair(0, 0).gamma, 4.5);

  EXPECT_EQ(s.box.lo, (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(s.box.hi, (std::array<double, 3>{10, 10, 10}));
  EXPECT_EQ(s.box.periodic, (std::array<bool, 3>{true, true, true}));

  ASSERT_EQ(s.init.size(), 1u);
  EXPECT_EQ(s.init[0].kind, InitSpec::Kind::Random);
  EXPECT_EQ(s.init[0].type, "fluid");
  EXPECT_EQ(s.init[0].density, 6.5);
  EXPECT_FALSE(s.init[0].count.has_value());
  EXPECT_EQ(s.init[0].lo, s.box.lo);
  EXPECT_EQ(s.init[0].hi, s.box.hi);

  ASSERT_EQ(s.stages.size(), 2u);
  EXPECT_EQ(s.stages[0].name, "equilibrate");
  EXPECT_EQ(s.stages[0].steps, 1000u);
  EXPECT_EQ(s.stages[0].dt, 0.01);
  EXPECT_EQ(s.stages[1].name, "sample");
  EXPECT_EQ(s.stages[1].steps, 2000u);
  EXPECT_EQ(s.stages[1].dt, 0.005);

  EXPECT_EQ(s.output.thermo_every, 100u);
  EXPECT_EQ(s.output.snapshot_every, 0u);
  EXPECT_TRUE(s.output.final_snapshot);
}

TEST(Scene, OptionalKeysTakeTheirDefaults) {
  const Scene s = parse_scene(R"(
[box]
lo = [0, 0, 0]
hi = [4, 4, 4]
[model]
conservative = "mdpd"
[[types]]
name = "f"
[[pairs]]
types = ["f", "f"]
A = -40
B = 25
gamma = 4.5
[[init]]
kind = "random"
type = "f"
count = 12
[[run]]
steps = 0
dt = 0.1
)",
                              "some/dir/minimal.toml");
  EXPECT_EQ(s.name, "minimal");  // the file stem
  EXPECT_EQ(s.model.seed, 1u);
  EXPECT_EQ(s.model.precision, sim::Precision::Double);
  EXPECT_EQ(s.model.density_kernel, sim::DensityKernelKind::Warren);
  EXPECT_EQ(s.model.rd, 0.75);
  EXPECT_TRUE(s.model.thermostat);
  EXPECT_EQ(s.model.kBT, 1.0);
  EXPECT_EQ(s.model.lambda, 0.5);
  EXPECT_EQ(s.box.periodic, (std::array<bool, 3>{true, true, true}));
  EXPECT_EQ(s.init[0].count, 12);
  EXPECT_FALSE(s.init[0].density.has_value());
  EXPECT_EQ(s.stages[0].name, "stage1");
  EXPECT_EQ(s.stages[0].steps, 0u);
  EXPECT_EQ(s.output.thermo_every, 100u);
  EXPECT_EQ(s.output.snapshot_every, 0u);
  EXPECT_TRUE(s.output.final_snapshot);
}

TEST(Scene, DpdSceneWithoutThermostatAndAllOptions) {
  const Scene s = parse_scene(R"(
name = "dpd-two"
seed = 9007199254740993
precision = "single"
[box]
lo = [-5, 0, 0]
hi = [5, 3, 4.5]
boundary = ["periodic", "reflective", "periodic"]
[model]
conservative = "dpd"
thermostat = false
kBT = 0.8
lambda = 0.65
[[types]]
name = "a"
body_force = [0.0, 0.0, 0.02]
[[types]]
name = "b"
frozen = true
[[pairs]]
types = ["b", "a"]
a = 30
[[pairs]]
types = ["a", "a"]
a = 25.0
[[pairs]]
types = ["b", "b"]
a = 0
[[init]]
kind = "lattice"
type = "b"
density = 3.0
lo = [-5, 0, 0]
hi = [5, 3, 1]
[[init]]
kind = "random"
type = "a"
count = 50
lo = [-5, 0, 1]
hi = [5, 3, 4.5]
[[run]]
name = "only"
steps = 3
dt = 0.02
[output]
thermo_every = 0
snapshot_every = 10
final_snapshot = false
)",
                              "dpd.toml");
  EXPECT_EQ(s.name, "dpd-two");
  EXPECT_EQ(s.model.seed, 9007199254740993ull);
  EXPECT_EQ(s.model.precision, sim::Precision::Single);
  EXPECT_EQ(s.model.conservative, sim::ConservativeKind::DPD);
  EXPECT_FALSE(s.model.thermostat);
  EXPECT_EQ(s.model.kBT, 0.8);
  EXPECT_EQ(s.model.lambda, 0.65);
  EXPECT_EQ(s.box.periodic, (std::array<bool, 3>{true, false, true}));
  ASSERT_EQ(s.model.ntypes(), 2);
  EXPECT_EQ(s.model.types[0].body_force, (std::array<double, 3>{0, 0, 0.02}));
  EXPECT_TRUE(s.model.types[1].frozen);
  // a is stored as Model A, symmetrically; B and gamma stay 0.
  EXPECT_EQ(s.model.pair(0, 1).A, 30.0);
  EXPECT_EQ(s.model.pair(1, 0).A, 30.0);
  EXPECT_EQ(s.model.pair(0, 0).A, 25.0);
  EXPECT_EQ(s.model.pair(1, 1).A, 0.0);
  for (const auto& p : s.model.pairs) {
    EXPECT_EQ(p.B, 0.0);
    EXPECT_EQ(p.gamma, 0.0);
  }
  ASSERT_EQ(s.init.size(), 2u);
  EXPECT_EQ(s.init[0].kind, InitSpec::Kind::Lattice);
  EXPECT_EQ(s.init[0].hi, (std::array<double, 3>{5, 3, 1}));
  EXPECT_EQ(s.init[1].count, 50);
  EXPECT_EQ(s.stages[0].name, "only");
  EXPECT_EQ(s.output.thermo_every, 0u);
  EXPECT_EQ(s.output.snapshot_every, 10u);
  EXPECT_FALSE(s.output.final_snapshot);
}

// [solid]: the mask is read (relative to the scene's folder) into the model with its settings;
// a missing file, a grid that does not fit the box, a bad value and an unknown key are one-line
// errors naming the file and the key.
TEST(Scene, SolidTableReadsTheMaskAndRefusesBadOnes) {
  TempDir dir;
  mesorock::sim::SolidMask m;
  m.dims = {16, 12, 10};
  m.voxel = {0.5, 0.5, 0.5};
  m.solid.assign(16 * 12 * 10, 0);
  m.solid[m.index(3, 4, 5)] = 1;
  mesorock::sim::write_solid_file(dir / "solid.h5", m, "test", "{}");
  auto scene_with = [&](const std::string& solid) {
    const fs::path p = dir / "s.toml";
    std::ofstream(p) << kTwoTypeScene
                     << "[[init]]\nkind = \"random\"\ntype = \"fluid\"\ncount = 10\n"
                     << solid;
    return p;
  };
  const Scene s =
      load_scene(scene_with("[solid]\nfile = \"solid.h5\"\nbounce = false\n"
                            "stop_depth = 0.25\nstop_count = 3\n"));
  ASSERT_TRUE(s.model.solid.mask);
  EXPECT_EQ(s.model.solid.mask->solid, m.solid);
  EXPECT_FALSE(s.model.solid.bounce);
  EXPECT_EQ(s.model.solid.stop_depth, 0.25);
  EXPECT_EQ(s.model.solid.stop_count, 3u);
  EXPECT_FALSE(load_scene(scene_with("")).model.solid.mask);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"[solid]\nfile = \"absent.h5\"\n",
       "solid.file: " + (dir / "absent.h5").string() + ": no such file"},
      {"[solid]\nfile = \"solid.h5\"\nstop_depth = 0\n", "solid.stop_depth: must be in (0, 4]"},
      {"[solid]\nfile = \"solid.h5\"\nstop_count = -1\n", "solid.stop_count: must be >= 0"},
      {"[solid]\nfile = \"solid.h5\"\nbouce = true\n", "bouce"},
      {"[solid]\nbounce = true\n", "solid.file"},
  };
  for (const auto& [text, message] : bad) {
    const std::string e = error_of([&] { load_scene(scene_with(text)); });
    EXPECT_NE(e.find(message), std::string::npos) << text << " -> " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
  m.dims = {20, 12, 10};  // 10 rc along x: longer than the box's 8
  m.solid.assign(20 * 12 * 10, 0);
  mesorock::sim::write_solid_file(dir / "solid.h5", m, "test", "{}");
  const std::string e = error_of([&] { load_scene(scene_with("[solid]\nfile = \"solid.h5\"\n")); });
  EXPECT_NE(e.find("does not fit in the box"), std::string::npos) << e;
}

TEST(Scene, MissingSceneFileIsAnIoError) {
  TempDir dir;
  const fs::path path = dir.path() / "absent.toml";
  try {
    load_scene(path);
    FAIL() << "no error";
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ": cannot open scene file");
  }
  EXPECT_THROW(load_scene(dir.path()), IoError);  // a folder is not a scene file
}

// ---------------------------------------------------------------------------------------------
// Bad scenes: one parameterised case per file in tests/data/scenes/bad/

namespace {

struct BadScene {
  fs::path path;
  std::string expect;
};

// gtest prints a failing parameter with this (instead of its bytes).
void PrintTo(const BadScene& b, std::ostream* os) {
  *os << b.path.filename().string();
}

std::vector<BadScene> bad_scenes() {
  std::vector<BadScene> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(kScenes / "bad", ec)) {
    if (e.path().extension() != ".toml") continue;
    std::ifstream in(e.path());
    std::string first;
    std::getline(in, first);
    const std::string tag = "# expect: ";
    BadScene b{e.path(), first.rfind(tag, 0) == 0 ? first.substr(tag.size()) : std::string()};
    out.push_back(b);
  }
  std::sort(out.begin(), out.end(),
            [](const BadScene& a, const BadScene& b) { return a.path < b.path; });
  return out;
}

std::string case_name(const testing::TestParamInfo<BadScene>& info) {
  std::string s = info.param.path.stem().string();
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

size_t files_under(const fs::path& dir) {
  size_t n = 0;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return 0;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (!e.is_directory()) ++n;
  return n;
}

}  // namespace

TEST(BadSceneFolder, HoldsEnoughCasesEachWithAnExpectation) {
  const auto all = bad_scenes();
  EXPECT_GE(all.size(), 14u);
  for (const auto& b : all) EXPECT_FALSE(b.expect.empty()) << b.path << ": no '# expect: ' line";
}

class BadSceneTest : public testing::TestWithParam<BadScene> {};

TEST_P(BadSceneTest, LoadSceneGivesOneLineNamingFileAndKey) {
  const BadScene& b = GetParam();
  ASSERT_FALSE(b.expect.empty()) << b.path << ": first line must be '# expect: <substring>'";
  const std::string msg = error_of([&] { load_scene(b.path); });
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind(b.path.string() + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find(b.expect), std::string::npos)
      << "message: " << msg << "\nexpected to contain: " << b.expect;
  // Bad scenes are ConfigErrors (a missing file would be an IoError, but these files exist).
  EXPECT_THROW(load_scene(b.path), ConfigError);
  // parse_scene on the same text reports the same.
  EXPECT_EQ(error_of([&] { parse_scene(read_file(b.path), b.path); }), msg);
}

TEST_P(BadSceneTest, RockflowRunExitsTwoWithOneLineAndWritesNothing) {
  const BadScene& b = GetParam();
  TempDir dir;
  const fs::path out = dir.path() / "out";
  const auto r =
      run_command(shell_quote(MESOROCK_ROCKFLOW) + " run " + shell_quote(b.path.string()) +
                      " --out " + shell_quote(out.string()),
                  dir.path());
  EXPECT_EQ(r.exit_code, 2) << "stderr: " << r.err;
  const std::string& err = r.err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_TRUE(!err.empty() && err.back() == '\n') << err;
  EXPECT_NE(err.find(b.path.filename().string()), std::string::npos) << err;
  EXPECT_NE(err.find(b.expect), std::string::npos) << err;
  EXPECT_EQ(files_under(out), 0u) << "rockflow wrote into " << out;
}

INSTANTIATE_TEST_SUITE_P(Files, BadSceneTest, testing::ValuesIn(bad_scenes()), case_name);

// Errors that need a generated file or a specific value rather than a fixed file.
TEST(Scene, ErrorMessagesQuoteTheBadValue) {
  const std::string base = kTwoTypeScene;
  const auto with_pair_gamma = [&](const std::string& g) {
    std::string t = base;
    const std::string key = "types = [\"wall\", \"fluid\"]\nA = -30\nB = 25\ngamma = 4.5";
    t.replace(t.find(key), key.size(),
              "types = [\"wall\", \"fluid\"]\nA = -30\nB = 25\ngamma = " + g);
    return t + "[[init]]\nkind = \"random\"\ntype = \"fluid\"\ncount = 3\n";
  };
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("-1"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be >= 0 (got -1)");
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("-0.125"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be >= 0 (got -0.125)");
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("nan"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be a finite number (got nan)");
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("-inf"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be a finite number (got -inf)");
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("[1.0]"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be a number (got array)");
  EXPECT_EQ(error_of([&] { parse_scene(with_pair_gamma("true"), "bad.toml"); }),
            "bad.toml: pairs[1].gamma: must be a number (got boolean true)");
  // The same text is valid with a good gamma.
  EXPECT_NO_THROW(parse_scene(with_pair_gamma("0.5"), "good.toml"));
}

// ---------------------------------------------------------------------------------------------
// Initial particles

TEST(InitialParticles, RandomDensityBlockIsReproducibleAndThermal) {
  const Scene s = load_scene(kScenes / "good_bulk.toml");
  const sim::ParticleSet p = build_initial_particles(s);
  ASSERT_EQ(p.size(), 6500u);  // llround(6.5 * 1000)
  std::set<std::int64_t> ids(p.id.begin(), p.id.end());
  EXPECT_EQ(ids.size(), p.size());
  EXPECT_EQ(*ids.begin(), 0);
  EXPECT_EQ(*ids.rbegin(), 6499);
  double sum[3] = {0, 0, 0}, v2 = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    for (double c : {p.x[i], p.y[i], p.z[i]}) {
      EXPECT_GE(c, 0.0);
      EXPECT_LT(c, 10.0);
    }
    sum[0] += p.vx[i];
    sum[1] += p.vy[i];
    sum[2] += p.vz[i];
    v2 += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
  }
  for (double m : sum) EXPECT_NEAR(m, 0.0, 1e-9);  // centre-of-mass velocity removed
  const double T = v2 / (3.0 * static_cast<double>(p.size()));
  EXPECT_NEAR(T, s.model.kBT, 0.05);  // 19500 degrees of freedom: sd of T ~ 0.01

  // Positions come from the documented block seed.
  sim::ParticleSet direct;
  std::int64_t next = 0;
  sim::fill_random(direct, 0, s.init[0].lo, s.init[0].hi, 6500,
                   mesorock::pipeline::init_block_seed(42, 0), next);
  EXPECT_EQ(direct.x, p.x);
  EXPECT_EQ(direct.z, p.z);

  const sim::ParticleSet again = build_initial_particles(s);
  EXPECT_EQ(again.x, p.x);
  EXPECT_EQ(again.vy, p.vy);

  Scene other = s;
  other.model.seed = 43;
  const sim::ParticleSet q = build_initial_particles(other);
  EXPECT_NE(q.x, p.x);
  EXPECT_NE(q.vx, p.vx);
}

TEST(InitialParticles, BlockSeedsDifferPerBlockAndFromVelocitySeed) {
  using mesorock::pipeline::init_block_seed;
  using mesorock::pipeline::init_velocity_seed;
  std::set<std::uint64_t> seeds{init_velocity_seed(1)};
  for (size_t k = 0; k < 100; ++k) seeds.insert(init_block_seed(1, k));
  for (size_t k = 0; k < 100; ++k) seeds.insert(init_block_seed(2, k));
  EXPECT_EQ(seeds.size(), 201u);
}

TEST(InitialParticles, LatticeAndCountBlocksWithFrozenWall) {
  const Scene s = parse_scene(std::string(kTwoTypeScene) + R"(
[[init]]
kind = "lattice"
type = "wall"
density = 8.0
lo = [0, 0, 0]
hi = [8, 6, 1]
[[init]]
kind = "random"
type = "fluid"
count = 1000
lo = [0, 0, 1]
hi = [8, 6, 5]
)",
                              "two.toml");
  const sim::ParticleSet p = build_initial_particles(s);
  // Lattice spacing 0.5: 16 x 12 x 2 sites.
  size_t walls = 0, fluids = 0;
  std::set<std::int64_t> ids(p.id.begin(), p.id.end());
  EXPECT_EQ(ids.size(), p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    if (p.type[i] == 1) {
      ++walls;
      EXPECT_LT(p.z[i], 1.0);
      EXPECT_EQ(p.vx[i], 0.0);
      EXPECT_EQ(p.vy[i], 0.0);
      EXPECT_EQ(p.vz[i], 0.0);
    } else {
      ++fluids;
      EXPECT_GE(p.z[i], 1.0);
      EXPECT_LT(p.z[i], 5.0);
    }
  }
  EXPECT_EQ(walls, 16u * 12u * 2u);
  EXPECT_EQ(fluids, 1000u);
  // Ids continue across blocks.
  EXPECT_EQ(p.id[walls], static_cast<std::int64_t>(walls));
}

TEST(InitialParticles, FileBlockMapsTypeNamesKeepsVelocitiesAndShiftsIds) {
  TempDir dir;
  sim::ParticleSet f;
  // Stored type 0 = "wall", 1 = "fluid": the reverse of the scene's order.
  f.add(1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0, 0);
  f.add(2.0, 2.0, 2.0, 0.5, -0.25, 0.125, 1, 1);
  f.add(3.0, 3.0, 3.0, -1.5, 2.0, 0.0, 1, 5);
  sim::ParticleFileMeta meta;
  meta.type_names = {"wall", "fluid"};
  meta.box.hi = {8, 6, 5};
  sim::write_particle_file(dir.path() / "walls.h5", f, meta);

  // Random block first (ids 0..9), then the file: its ids 0, 1, 5 shift to 10, 11, 15.
  const std::string rnd = "[[init]]\nkind = \"random\"\ntype = \"fluid\"\ncount = 10\n";
  const std::string file = "[[init]]\nkind = \"file\"\nfile = \"walls.h5\"\n";
  write_text(dir.path() / "a.toml", std::string(kTwoTypeScene) + rnd + file);
  const sim::ParticleSet p = build_initial_particles(load_scene(dir.path() / "a.toml"));
  ASSERT_EQ(p.size(), 13u);
  EXPECT_EQ(std::vector<std::int64_t>(p.id.begin() + 10, p.id.end()),
            (std::vector<std::int64_t>{10, 11, 15}));
  EXPECT_EQ(std::vector<std::int32_t>(p.type.begin() + 10, p.type.end()),
            (std::vector<std::int32_t>{1, 0, 0}));  // wall = 1, fluid = 0 in the scene
  EXPECT_EQ(p.vx[11], 0.5);
  EXPECT_EQ(p.vy[11], -0.25);
  EXPECT_EQ(p.vz[11], 0.125);
  EXPECT_EQ(p.vx[12], -1.5);
  EXPECT_EQ(p.x[12], 3.0);

  // File first keeps its ids; the random block continues past the largest (5).
  write_text(dir.path() / "b.toml", std::string(kTwoTypeScene) + file + rnd);
  const sim::ParticleSet q = build_initial_particles(load_scene(dir.path() / "b.toml"));
  ASSERT_EQ(q.size(), 13u);
  EXPECT_EQ(std::vector<std::int64_t>(q.id.begin(), q.id.begin() + 4),
            (std::vector<std::int64_t>{0, 1, 5, 6}));
  EXPECT_EQ(q.vx[1], 0.5);  // file particles keep their velocities
  std::set<std::int64_t> ids(q.id.begin(), q.id.end());
  EXPECT_EQ(ids.size(), q.size());
}

TEST(InitialParticles, FileBlockErrorsNameSceneBlockAndFile) {
  TempDir dir;
  sim::ParticleSet f;
  f.add(1.0, 1.0, 1.0, 0, 0, 0, 0, 0);
  f.add(2.0, 2.0, 7.5, 0, 0, 0, 0, 1);  // z beyond the scene box (hi z = 5)
  sim::ParticleFileMeta meta;
  meta.type_names = {"fluid"};
  meta.box.hi = {10, 10, 10};
  sim::write_particle_file(dir.path() / "tall.h5", f, meta);
  meta.type_names = {"oil"};
  sim::write_particle_file(dir.path() / "oil.h5", f, meta);
  write_text(dir.path() / "garbage.h5", "this is not an HDF5 file\n");

  const auto scene_with = [&](const std::string& name, const std::string& h5) {
    const fs::path p = dir.path() / name;
    write_text(p, std::string(kTwoTypeScene) +
                      "[[init]]\nkind = \"random\"\ntype = \"fluid\"\ncount = 4\n"
                      "[[init]]\nkind = \"file\"\nfile = \"" +
                      h5 + "\"\n");
    return p;
  };

  const fs::path a = scene_with("outside.toml", "tall.h5");
  std::string msg = error_of([&] { build_initial_particles(load_scene(a)); });
  EXPECT_EQ(msg.rfind(a.string() + ": init[1]: particle 1 of ", 0), 0u)
      << msg;  // its id in the file
  EXPECT_NE(msg.find("tall.h5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("outside the box [0, 8] x [0, 6] x [0, 5]"), std::string::npos) << msg;

  const fs::path b = scene_with("oil.toml", "oil.h5");
  msg = error_of([&] { build_initial_particles(load_scene(b)); });
  EXPECT_EQ(msg.rfind(b.string() + ": init[1].file: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("oil.h5: type \"oil\" is not a type of this scene (types: fluid, wall)"),
            std::string::npos)
      << msg;
  EXPECT_THROW(build_initial_particles(load_scene(b)), ConfigError);

  const fs::path c = scene_with("garbage.toml", "garbage.h5");
  msg = error_of([&] { build_initial_particles(load_scene(c)); });
  EXPECT_EQ(msg.rfind(c.string() + ": init[1].file: " + (dir.path() / "garbage.h5").string() +
                          ": cannot open as an HDF5 file",
                      0),
            0u)
      << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos);
  EXPECT_THROW(build_initial_particles(load_scene(c)), IoError);
}

// ---------------------------------------------------------------------------------------------
// Scenes shipped in the repository

TEST(Scene, DocsExampleParses) {
  const std::string doc = read_file(fs::path(MESOROCK_SOURCE_DIR) / "docs" / "scene.md");
  const size_t start = doc.find("```toml\n");
  ASSERT_NE(start, std::string::npos) << "docs/scene.md has no ```toml example";
  const size_t body = start + 8;
  const size_t end = doc.find("```", body);
  ASSERT_NE(end, std::string::npos);
  const Scene s = parse_scene(doc.substr(body, end - body), "docs/scene.md-example.toml");
  EXPECT_EQ(s.name, "slit-demo");
  EXPECT_EQ(s.box.periodic, (std::array<bool, 3>{true, true, false}));
  ASSERT_EQ(s.model.ntypes(), 2);
  EXPECT_EQ(s.model.pair(1, 0).A, -30.0);
  EXPECT_EQ(s.model.types[0].body_force[0], 0.02);
  ASSERT_EQ(s.init.size(), 2u);
  ASSERT_EQ(s.stages.size(), 2u);
  const sim::ParticleSet p = build_initial_particles(s);
  // Lattice: spacing 0.5 -> 24 x 16 x 2 sites; random: llround(6.5 * 10 * 8 * 9).
  EXPECT_EQ(p.size(), 768u + 4680u);
  // The example is a runnable scene: the solver accepts it (walls, virtual wall, particles).
  EXPECT_NO_THROW(sim::make_simulation(s.model, s.box, p, s.stages.front().dt));
}

TEST(Scene, SampleScenesParse) {
  const fs::path samples = fs::path(MESOROCK_SOURCE_DIR) / "samples";
  size_t n = 0;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(samples, ec)) {
    if (e.path().extension() != ".toml") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_NO_THROW(load_scene(e.path()));
    ++n;
  }
  EXPECT_GE(n, 1u);
}
