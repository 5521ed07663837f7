// Checkpoints (sim/checkpoint.h): a simulation resumed from Simulation::state() continues bit for
// bit what the uninterrupted one computes, with every piece of state that carries over a step in
// play (thermostat v~, wall model and its corrections, a rigid slab, a virtual wall, a body
// force); the HDF5 file round-trips the state exactly; a state that does not fit the model is
// refused. One body for every backend.
#include <gtest/gtest.h>

#include <hdf5.h>

#include <cstring>
#include <fstream>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/checkpoint.h"
#include "sim/init.h"
#include "sim/simulation.h"
#include "support/test_support.h"

namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

struct System {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

// Fluid between a frozen wall (z < 1, with the wall model) and a rigid slab pushing down (z near
// 7), driven along x; a virtual wall keeps the fluid below z = 6 for the first 30 steps.
System mixed(ms::Precision precision) {
  System s;
  s.model.precision = precision;
  s.model.seed = 5;
  const int fluid = s.model.add_type({"fluid", false, {0.05, 0, 0}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  const int piston = s.model.add_type({"piston", false, {0, 0, 0}});
  for (int a : {fluid, wall, piston})
    for (int b : {fluid, wall, piston}) s.model.set_pair(a, b, {-40, 25, 4.5});
  s.model.wall_model.enabled = true;
  s.model.wall_model.wall_types = 1u << wall;
  s.model.rigid_slabs.push_back({piston, 2, -5.0});
  s.model.virtual_walls.push_back({2, 6.0, 1u << fluid, true, 30});
  s.box.hi = {4, 4, 8};
  s.box.periodic = {true, true, false};
  std::int64_t next = 0;
  ms::fill_lattice(s.particles, wall, {0, 0, 0}, {4, 4, 1}, 8, next);
  ms::fill_random(s.particles, fluid, {0, 0, 1}, {4, 4, 5.9}, 520, 5, next);
  ms::fill_lattice(s.particles, piston, {0, 0, 6.5}, {4, 4, 7.5}, 6, next);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 5);
  return s;
}

void expect_same_bits(const std::vector<double>& a, const std::vector<double>& b,
                      const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << what;
}

void expect_same_particles(const ms::ParticleSet& a, const ms::ParticleSet& b) {
  expect_same_bits(a.x, b.x, "x");
  expect_same_bits(a.y, b.y, "y");
  expect_same_bits(a.z, b.z, "z");
  expect_same_bits(a.vx, b.vx, "vx");
  expect_same_bits(a.vy, b.vy, "vy");
  expect_same_bits(a.vz, b.vz, "vz");
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.id, b.id);
}

class Checkpoint : public OnEveryBackend {};

TEST_P(Checkpoint, ResumedRunIsBitForBitTheUninterruptedOne) {
  for (auto precision : {ms::Precision::Double, ms::Precision::Single}) {
    System s = mixed(precision);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    sim->run(20);  // the virtual wall is still up at the checkpoint
    sim->set_dt(0.008);
    sim->run(5);
    const ms::SimulationState saved = sim->state();
    ASSERT_EQ(saved.step, 25u);
    EXPECT_EQ(saved.dt, 0.008);
    sim->run(60);
    const ms::ParticleSet uninterrupted = sim->particles();
    const auto slabs = sim->rigid_slabs();
    const auto corrections = sim->wall_corrections();
    EXPECT_GT(corrections, 0u) << "the wall model should have corrected some particles";

    // Through the file, and on the CPU with another thread count.
    mesorock::test::TempDir dir;
    ms::CheckpointFile file;
    file.state = saved;
    file.created_by = "test";
    file.scene_text = "scene";
    file.texts["thermo.csv"] = "step,T\n10,1.0\n";
    file.numbers["series"] = {1.5, -2.25};
    ms::write_checkpoint(dir / "checkpoint.h5", file);
    const ms::CheckpointFile back = ms::read_checkpoint(dir / "checkpoint.h5");
    EXPECT_EQ(back.texts.at("thermo.csv"), "step,T\n10,1.0\n");
    EXPECT_EQ(back.numbers.at("series"), (std::vector<double>{1.5, -2.25}));
    EXPECT_EQ(back.scene_text, "scene");
    EXPECT_FALSE(back.mesorock_version.empty());
    ms::SimulationOptions other = options();
    other.threads = 1;
    auto resumed = ms::resume_simulation(s.model, s.box, back.state, other);
    EXPECT_EQ(resumed->step(), 25u);
    EXPECT_EQ(resumed->dt(), 0.008);
    expect_same_particles(resumed->particles(), saved.particles());
    resumed->run(60);
    expect_same_particles(resumed->particles(), uninterrupted);
    EXPECT_EQ(resumed->wall_corrections(), corrections);
    const auto rslabs = resumed->rigid_slabs();
    ASSERT_EQ(rslabs.size(), 1u);
    EXPECT_EQ(rslabs[0].position, slabs[0].position);
    EXPECT_EQ(rslabs[0].velocity, slabs[0].velocity);
    EXPECT_EQ(rslabs[0].force, slabs[0].force);
  }
}

TEST_P(Checkpoint, StateThatDoesNotFitTheModelIsRefused) {
  System s = mixed(ms::Precision::Double);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  sim->run(3);
  const ms::SimulationState saved = sim->state();
  ms::Model single = s.model;
  single.precision = ms::Precision::Single;
  EXPECT_THROW(ms::resume_simulation(single, s.box, saved, options()), mesorock::ConfigError);
  ms::Model no_walls = s.model;
  no_walls.wall_model.enabled = false;
  EXPECT_THROW(ms::resume_simulation(no_walls, s.box, saved, options()), mesorock::ConfigError);
  ms::SimulationState broken = saved;
  broken.origin[0] = broken.origin[1];
  EXPECT_THROW(ms::resume_simulation(s.model, s.box, broken, options()), mesorock::ConfigError);
  broken = saved;
  broken.fx.pop_back();
  EXPECT_THROW(ms::resume_simulation(s.model, s.box, broken, options()), mesorock::ConfigError);
}

MESOROCK_ON_EVERY_BACKEND(Checkpoint);

TEST(CheckpointFile, MissingOrForeignFilesAreIoErrors) {
  mesorock::test::TempDir dir;
  EXPECT_THROW(ms::read_checkpoint(dir / "none.h5"), mesorock::IoError);
  {
    std::ofstream out(dir / "text.h5");
    out << "not hdf5";
  }
  EXPECT_THROW(ms::read_checkpoint(dir / "text.h5"), mesorock::IoError);
  try {
    ms::read_checkpoint(dir / "text.h5");
  } catch (const mesorock::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("text.h5"), std::string::npos) << e.what();
  }
}

// The byte offset in the file of a contiguous dataset's data.
haddr_t data_offset(const std::filesystem::path& file, const std::string& dataset) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t d = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
  const haddr_t at = d >= 0 ? H5Dget_offset(d) : HADDR_UNDEF;
  if (d >= 0) H5Dclose(d);
  H5Fclose(f);
  return at;
}

// Issue 58: a flipped mantissa bit, a changed velocity, a changed thermo digit or step all
// resumed with exit 0. Each dataset carries a checksum now: one bit flipped anywhere in the data
// of any of these datasets is refused, naming the dataset.
TEST(CheckpointFile, OneFlippedBitInAnyDatasetIsRefusedNamingIt) {
  System s = mixed(ms::Precision::Double);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, ms::SimulationOptions{});
  sim->run(3);
  mesorock::test::TempDir dir;
  ms::CheckpointFile file;
  file.state = sim->state();
  file.created_by = "test";
  file.scene_text = "scene";
  file.input_files = "0123456789abcdef solid.h5\n";
  file.texts["thermo.csv"] = "step,T\n0,1.0\n";
  file.numbers["series"] = {1.5, -2.25};
  const std::filesystem::path good = dir / "good.h5";
  ms::write_checkpoint(good, file);
  ASSERT_NO_THROW(ms::read_checkpoint(good));
  const std::string bytes = mesorock::test::read_file(good);
  struct Flip {
    const char* dataset;
    std::size_t byte;
    int bit;
  };
  const Flip flips[] = {{"/checkpoint/x", 8 * 17 + 2, 3},   // a mantissa bit
                        {"/checkpoint/vx", 8 * 40 + 7, 6},  // an exponent bit
                        {"/checkpoint/fz", 8 * 5, 0},       // the lowest bit
                        {"/checkpoint/id", 8 * 9, 1},       // a duplicated-looking id
                        {"/checkpoint/origin", 4 * 3, 0},   // still a permutation? no matter
                        {"/checkpoint/step", 0, 3},         // step 3 -> 11
                        {"/checkpoint/type", 4 * 100, 0},   // another type
                        {"/checkpoint/bvf", 8 * 2 + 6, 4},  // the wall model's state
                        {"/run/text/thermo.csv", 9, 0},     // a thermo digit
                        {"/run/numbers/series", 8 + 3, 5},  // a saved series
                        {"/meta/scene_text", 2, 1},         // the scene's text
                        {"/meta/input_files", 0, 0},        // a recorded input checksum
                        {"/meta/checksums", 3, 0}};         // the table itself
  for (const Flip& flip : flips) {
    const haddr_t at = data_offset(good, flip.dataset);
    ASSERT_NE(at, HADDR_UNDEF) << flip.dataset;
    std::string damaged = bytes;
    ASSERT_LT(at + flip.byte, damaged.size()) << flip.dataset;
    damaged[at + flip.byte] = static_cast<char>(damaged[at + flip.byte] ^ (1 << flip.bit));
    const std::filesystem::path bad = dir / "bad.h5";
    std::ofstream(bad, std::ios::binary) << damaged;
    try {
      ms::read_checkpoint(bad);
      ADD_FAILURE() << flip.dataset << ": a flipped bit was read without a word";
    } catch (const mesorock::IoError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(std::string("bad.h5: ") + flip.dataset + ":"), std::string::npos) << what;
    }
  }
}

}  // namespace
