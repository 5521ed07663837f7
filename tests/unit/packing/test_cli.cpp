// rockprep tiles and rockprep run on the command line: the documented outputs with provenance,
// a scene that the scene reader and `rockflow run` accept as written, exit code 2 with one line
// and no output for bad input, and exit code 1 from `tiles check` for a damaged set.
#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

#include "mesorock/output_lock.h"
#include "pipeline/prep/stokes_regime.h"
#include "pipeline/scene.h"
#include "sim/particle_io.h"
#include "support/test_support.h"
#include "tiledb/database.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"

namespace mesorock::packing {
namespace {

namespace fs = std::filesystem;
using mesorock::test::CommandResult;
using mesorock::test::run_command;
using mesorock::test::shell_quote;
using mesorock::test::TempDir;

std::string rockprep() {
  // One thread: these systems are tiny, and the results do not depend on it.
  return "OMP_NUM_THREADS=1 " + shell_quote(MESOROCK_ROCKPREP);
}

// A small tile database: 0.5 rc walls (rho 8) and fluid (rho 6.5), 512 tiles each.
const fs::path& small_db() {
  static TempDir dir;
  static const fs::path db = [] {
    const fs::path p = dir / "tiles.h5";
    for (const char* role : {"wall", "fluid"}) {
      const CommandResult r =
          run_command(rockprep() + " tiles build " + shell_quote(p.string()) + " --role " + role +
                          " --variants 500 --box-edge 4 --relax-steps 100"
                          " --equilibrate-steps 1000 --quiet",
                      dir.path());
      EXPECT_EQ(r.exit_code, 0) << r.err;
    }
    return p;
  }();
  return db;
}

TEST(PackingCli, TilesBuildListCheck) {
  TempDir tmp;
  const fs::path& db = small_db();
  CommandResult r = run_command(rockprep() + " tiles list " + shell_quote(db.string()), tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("set_000 wall, rho 8, tile 0.5 x 0.5 x 0.5 rc"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("set_001 fluid, rho 6.5"), std::string::npos) << r.out;
  r = run_command(rockprep() + " tiles check " + shell_quote(db.string()) + " --json", tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["pass"].get<bool>());
  ASSERT_EQ(j["sets"].size(), 2u);
  for (const auto& s : j["sets"]) {
    EXPECT_EQ(s["tiles"], 512);
    // Acceptance: density within 1%, temperature within 2% (tiny boxes, short runs).
    EXPECT_NEAR(s["measured_density"].get<double>() / s["density"].get<double>(), 1.0, 0.01);
    EXPECT_NEAR(s["temperature"].get<double>(), 1.0, 0.02);
    EXPECT_EQ(s["build"]["mesorock_version"].get<std::string>().empty(), false);
    EXPECT_TRUE(s["check"]["pass"].get<bool>());
  }
  // A damaged set fails the check with exit code 1.
  tiledb::TileDatabase d = tiledb::read_tile_database(db);
  d.sets[0].key.density = 8.5;  // the tiles have 8: 6% off
  const fs::path bad = tmp / "bad.h5";
  tiledb::write_tile_database(bad, d);
  r = run_command(rockprep() + " tiles check " + shell_quote(bad.string()), tmp.path());
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("FAIL"), std::string::npos) << r.out;
  // Not a database: exit code 2, one line naming the file.
  std::ofstream(tmp / "junk.h5") << "junk";
  r = run_command(rockprep() + " tiles list " + shell_quote((tmp / "junk.h5").string()),
                  tmp.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("junk.h5"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// A 12 x 16 x 20 voxel synthetic shale whose pores join the x faces (seed 3).
void make_stack(const TempDir& tmp) {
  const CommandResult r = run_command(
      "cd " + shell_quote(tmp.path().string()) + " && " + rockprep() +
          " synth --shape 12,16,20 --spacing 1,1,1 --unit nm --porosity 0.35 --organic 0.5"
          " --blob 5 --pore-radius 2.5 --matrix-pores 0.5 --noise 10 --seed 3 --quiet --out syn",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

TEST(PackingCli, RunWritesParticlesAndASceneThatRockflowRuns) {
  TempDir tmp;
  make_stack(tmp);
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && ";
  CommandResult r = run_command(
      cd + rockprep() + " run syn/truth.mhd --rc-per-voxel 0.5 --tiles " +
          shell_quote(small_db().string()) +
          " --relax-steps 10 --settle-steps 20 --flood-steps 20 --region-every 10 --lammps"
          " --seed 5 --out setup",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("rockprep: summary: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("peak memory"), std::string::npos) << r.out;
  for (const char* f :
       {"particles.h5", "particles.xmf", "particles.data", "scene.toml", "tiles.h5", "run.json"})
    EXPECT_TRUE(fs::exists(tmp / "setup" / f)) << f;
  const auto run = nlohmann::json::parse(mesorock::test::read_file(tmp / "setup" / "run.json"));
  EXPECT_EQ(run["tool"], "rockprep");
  EXPECT_EQ(run["command"], "run");
  EXPECT_EQ(run["parameters"]["seed"], 5);
  EXPECT_GE(run["voxels"]["spanning_clusters"].get<int>(), 1);
  // Particles: the file holds what run.json counts, of the scene's types, inside the box.
  sim::ParticleFileMeta meta;
  const sim::ParticleSet p = sim::read_particle_file(tmp / "setup" / "particles.h5", &meta);
  EXPECT_EQ(static_cast<std::int64_t>(p.size()), run["particles"]["total"].get<std::int64_t>());
  EXPECT_EQ(meta.created_by, "rockprep run");
  std::vector<std::int64_t> per_type(meta.type_names.size(), 0);
  for (size_t i = 0; i < p.size(); ++i) {
    ++per_type[static_cast<size_t>(p.type[i])];
    ASSERT_GE(p.x[i], meta.box.lo[0]);
    ASSERT_LT(p.x[i], meta.box.hi[0]);
  }
  for (size_t t = 0; t < meta.type_names.size(); ++t)
    EXPECT_EQ(per_type[t], run["particles"]["by_type"][meta.type_names[t]].get<std::int64_t>())
        << meta.type_names[t];
  // Every role's count within 3 standard deviations of voxels x voxel volume x density.
  for (const auto& role : run["particles"]["by_role"]) {
    const double n = role["particles"].get<double>(), e = role["expected"].get<double>(),
                 s = role["standard_deviation"].get<double>();
    EXPECT_LE(std::abs(n - e), 3 * s + 1e-9) << role.dump();
  }
  // The scene reads as written and names the particle file.
  const pipeline::Scene scene = pipeline::load_scene(tmp / "setup" / "scene.toml");
  EXPECT_EQ(scene.model.rigid_slabs.size(), 2u);
  EXPECT_EQ(scene.model.virtual_walls.size(), 2u);
  EXPECT_TRUE(scene.model.wall_model.enabled);
  EXPECT_NEAR(scene.model.wall_model.wall_density, 8.0, 1e-9);
  ASSERT_EQ(scene.output.regions.size(), 3u);
  EXPECT_EQ(scene.output.regions[0].saturation_of, "source");
  EXPECT_DOUBLE_EQ(scene.units.nm_per_rc, 2.0);  // 1 nm voxels at 0.5 rc per voxel
  // rockflow runs it as is.
  r = run_command(
      cd + shell_quote(MESOROCK_ROCKFLOW) + " run setup/scene.toml --out flood --threads 1",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string sat = mesorock::test::read_file(tmp / "flood" / "saturation.csv");
  EXPECT_NE(sat.find("\n50,"), std::string::npos) << sat;  // steps 0 .. 50 every 10
  EXPECT_TRUE(fs::exists(tmp / "flood" / "slabs.csv"));
  // The LAMMPS file has every particle.
  const std::string data = mesorock::test::read_file(tmp / "setup" / "particles.data");
  EXPECT_NE(data.find(std::to_string(p.size()) + " atoms\n"), std::string::npos);
  // Same seed and tiles: the same particles.
  r = run_command(cd + rockprep() + " run syn/truth.mhd --rc-per-voxel 0.5 --tiles " +
                      shell_quote(small_db().string()) + " --seed 5 --quiet --out again",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const sim::ParticleSet q = sim::read_particle_file(tmp / "again" / "particles.h5");
  EXPECT_EQ(q.x, p.x);
  EXPECT_EQ(q.vx, p.vx);
}

// --layout permeability: the block and its mirror image along x in a box periodic on every axis,
// one fluid type driven along x, walls as in the flooding layout, and nothing else; the scene is
// accepted by the reader, `rockflow run` and `rockflow sweep` (which finds the driven type, the
// axis and the fluid density in it).
// Without any tiles (lattice walls, random fluid): the permeability layout has no slabs, so it
// needs none of their tiles (it stopped with "role 'pushing slab': no tiles"; issue 22, item 7).
TEST(PackingCli, RunPermeabilityLayoutPacksWithoutTiles) {
  TempDir tmp;
  make_stack(tmp);
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && ";
  const CommandResult r = run_command(
      cd + rockprep() +
          " run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --wall-fill lattice"
          " --fluid-fill random --seed 5 --out deep/er/perm",  // --out's parents are created
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const fs::path out = tmp / "deep" / "er" / "perm";
  const auto run = nlohmann::json::parse(mesorock::test::read_file(out / "run.json"));
  EXPECT_EQ(run["layout"]["kind"], "permeability");
  EXPECT_TRUE(fs::exists(out / "particles.h5"));
  EXPECT_TRUE(fs::exists(out / "solid.h5"));
  const pipeline::Scene scene = pipeline::load_scene(out / "scene.toml");
  EXPECT_GE(scene.model.type_index("fluid"), 0);
  // A parent that is a file is named, and nothing is written.
  std::ofstream(tmp / "afile") << "x";
  const CommandResult bad =
      run_command(cd + rockprep() + " run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability" +
                      " --wall-fill lattice --fluid-fill random --out afile/perm",
                  tmp.path());
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("afile is a file, not a folder"), std::string::npos) << bad.err;
}

TEST(PackingCli, RunPermeabilityLayoutWritesAPeriodicSampleForTheSweep) {
  TempDir tmp;
  make_stack(tmp);
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && ";
  CommandResult r = run_command(
      cd + rockprep() + " run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --tiles " +
          shell_quote(small_db().string()) +
          " --body-force 0.03 --relax-steps 10 --flow-steps 20 --region-every 10 --thermo-every 10"
          " --seed 5 --out perm",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("in the periodic box, mirrored"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("next: rockflow sweep"), std::string::npos) << r.out;
  const auto run = nlohmann::json::parse(mesorock::test::read_file(tmp / "perm" / "run.json"));
  EXPECT_EQ(run["parameters"]["layout"], "permeability");
  EXPECT_EQ(run["parameters"]["body_force"], 0.03);
  EXPECT_EQ(run["parameters"]["body_force_from"], "--body-force");
  EXPECT_NE(r.out.find("or watch it flow: rockflow run"), std::string::npos) << r.out;
  EXPECT_EQ(run["layout"]["kind"], "permeability");
  EXPECT_TRUE(run["layout"]["mirrored"].get<bool>());
  // The pore sizes travel with the particles (rockflow sweep's default warm-up), and the
  // suggested forces follow the median pore: the top one g = 2.29 / d^2.
  const double median = run.at("pore_sizes").at("median_rc").get<double>();
  const auto provenance = nlohmann::json::parse(
      sim::read_particle_file_meta(tmp / "perm" / "particles.h5").provenance_json);
  EXPECT_EQ(provenance.at("pore_sizes").at("median_rc").get<double>(), median);
  const std::size_t forces = r.out.find("--forces ");
  ASSERT_NE(forces, std::string::npos) << r.out;
  const std::string list = r.out.substr(forces + 9, r.out.find('\n', forces) - forces - 9);
  const double top = std::stod(list.substr(list.rfind(',') + 1));
  EXPECT_NEAR(top * median * median, pipeline::prep::kSweepForceTimesPore2, 0.01) << list;

  // The scene: periodic box twice the block's 20 voxels x 0.5 rc along x, the block's 8 and 6 rc
  // across; no slabs or virtual walls; one mobile type, driven along x; frozen walls with the
  // wall model.
  const pipeline::Scene scene = pipeline::load_scene(tmp / "perm" / "scene.toml");
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(scene.box.periodic[static_cast<size_t>(k)]) << k;
    EXPECT_DOUBLE_EQ(scene.box.lo[static_cast<size_t>(k)], 0.0) << k;
  }
  EXPECT_DOUBLE_EQ(scene.box.hi[0], 2 * 20 * 0.5);
  EXPECT_DOUBLE_EQ(scene.box.hi[1], 16 * 0.5);
  EXPECT_DOUBLE_EQ(scene.box.hi[2], 12 * 0.5);
  EXPECT_TRUE(scene.model.rigid_slabs.empty());
  EXPECT_TRUE(scene.model.virtual_walls.empty());
  EXPECT_TRUE(scene.model.wall_model.enabled);
  // Regions: the block (the first copy) and, mirrored, the whole box (the sweep's flux).
  ASSERT_EQ(scene.output.regions.size(), 2u);
  EXPECT_EQ(scene.output.regions[0].name, "block");
  EXPECT_DOUBLE_EQ(scene.output.regions[0].hi[0], 20 * 0.5);
  EXPECT_EQ(scene.output.regions[1].name, "box");
  EXPECT_EQ(scene.output.regions[1].lo, scene.box.lo);
  EXPECT_EQ(scene.output.regions[1].hi, scene.box.hi);
  EXPECT_NEAR(scene.model.wall_model.wall_density, 8.0, 0.08);  // the wall tiles' measured
  int mobile = -1;
  for (int t = 0; t < scene.model.ntypes(); ++t) {
    const sim::TypeSpec& type = scene.model.types[static_cast<size_t>(t)];
    if (type.frozen) {
      EXPECT_TRUE(type.name == "organic_wall" || type.name == "inorganic_wall") << type.name;
      EXPECT_EQ(type.body_force, (std::array<double, 3>{0, 0, 0})) << type.name;
      continue;
    }
    EXPECT_EQ(mobile, -1) << "a second mobile type " << type.name;
    mobile = t;
    EXPECT_EQ(type.name, "fluid");
    EXPECT_EQ(type.body_force, (std::array<double, 3>{0.03, 0, 0}));
  }
  ASSERT_GE(mobile, 0);

  // Particles: no fluid particle in a solid voxel of the true labels (x mirrored in the second
  // half). Walls are checked below, where no pore is dropped (a dropped pore becomes solid and
  // may hold walls).
  const voxel::Volume labels = voxel::read_mhd(tmp / "syn" / "truth.mhd");
  ASSERT_EQ(labels.shape().nx, 20);
  sim::ParticleFileMeta meta;
  const sim::ParticleSet p = sim::read_particle_file(tmp / "perm" / "particles.h5", &meta);
  EXPECT_EQ(meta.type_names[static_cast<size_t>(mobile)], "fluid");
  struct Placement {
    std::int64_t fluid = 0, misplaced_fluid = 0, misplaced_wall = 0;
  };
  auto placement = [&labels](const sim::ParticleSet& q, int fluid_type, bool mirrored_x) {
    const std::uint8_t* label = labels.data<std::uint8_t>();
    auto voxel_of = [](double c, std::int64_t n) {
      return std::min(n - 1, std::max<std::int64_t>(0, static_cast<std::int64_t>(c / 0.5)));
    };
    Placement m;
    for (size_t i = 0; i < q.size(); ++i) {
      std::int64_t x = voxel_of(q.x[i], mirrored_x ? 40 : 20);
      if (x >= 20) x = 39 - x;
      const std::int64_t y = voxel_of(q.y[i], 16), z = voxel_of(q.z[i], 12);
      const std::uint8_t code = label[(z * 16 + y) * 20 + x];
      const bool pore = code == static_cast<std::uint8_t>(voxel::Phase::kPore) ||
                        code == static_cast<std::uint8_t>(voxel::Phase::kOrganicPore);
      if (q.type[i] == fluid_type) {
        ++m.fluid;
        m.misplaced_fluid += pore ? 0 : 1;
      } else {
        m.misplaced_wall += pore ? 1 : 0;
      }
    }
    return m;
  };
  const Placement placed = placement(p, mobile, true);
  const std::int64_t fluid = placed.fluid;
  EXPECT_GT(fluid, 0);
  EXPECT_EQ(placed.misplaced_fluid, 0);
  // Counts: the fluid fills twice the block's (kept) pore voxels at density 6.5, within 3
  // standard deviations; every role within 3 of its own expectation.
  const double pore_voxels = run["voxels"]["pore"].get<double>();
  ASSERT_GT(pore_voxels, 0);
  EXPECT_EQ(run["voxels"]["box"].get<std::int64_t>(), 2 * 12 * 16 * 20);
  bool found_fluid_role = false;
  for (const auto& role : run["particles"]["by_role"]) {
    const double n = role["particles"].get<double>(), e = role["expected"].get<double>(),
                 sd = role["standard_deviation"].get<double>();
    EXPECT_LE(std::abs(n - e), 3 * sd + 1e-9) << role.dump();
    if (role["type"] == "fluid") {
      found_fluid_role = true;
      EXPECT_EQ(role["voxels"].get<double>(), 2 * pore_voxels);
      EXPECT_NEAR(e, 2 * pore_voxels * 0.125 * 6.5, 0.01 * e);  // tiles' density within 1%
      EXPECT_EQ(static_cast<double>(fluid), n);
      EXPECT_LE(std::abs(n - 2 * pore_voxels * 0.125 * 6.5), 3 * sd + 0.01 * e) << role.dump();
    }
  }
  EXPECT_TRUE(found_fluid_role);

  // solid.h5: the box's voxels, solid exactly where the (mirrored) labels are not pore, or where
  // a dropped pore cluster became solid; the scene hands it to the solver.
  ASSERT_TRUE(scene.model.solid.mask);
  const sim::SolidMask solid = sim::read_solid_file(tmp / "perm" / "solid.h5");
  EXPECT_EQ(solid.dims, (std::array<std::int64_t, 3>{40, 16, 12}));
  EXPECT_EQ(solid.voxel, (std::array<double, 3>{0.5, 0.5, 0.5}));
  {
    const std::uint8_t* label = labels.data<std::uint8_t>();
    std::int64_t solid_where_pore = 0, pore_where_solid = 0, pore_box = 0;
    for (std::int64_t z = 0; z < 12; ++z)
      for (std::int64_t y = 0; y < 16; ++y)
        for (std::int64_t x = 0; x < 40; ++x) {
          const std::int64_t bx = x < 20 ? x : 39 - x;
          const std::uint8_t code = label[(z * 16 + y) * 20 + bx];
          const bool pore = code == static_cast<std::uint8_t>(voxel::Phase::kPore) ||
                            code == static_cast<std::uint8_t>(voxel::Phase::kOrganicPore);
          const bool s = solid.is_solid(x, y, z);
          pore_where_solid += !pore && !s;
          solid_where_pore += pore && s;
          pore_box += !s;
        }
    EXPECT_EQ(pore_where_solid, 0);
    // Only the dropped (non-spanning) pore voxels may be solid, twice each (mirrored).
    EXPECT_EQ(solid_where_pore, 2 * run["voxels"]["pore_dropped"].get<std::int64_t>());
    EXPECT_EQ(pore_box, 2 * run["voxels"]["pore"].get<std::int64_t>());
  }

  // rockflow runs it as is (no fluid particle ever inside the solid: summary.json's invariant),
  // and rockflow sweep drives the fluid along x at the recorded density.
  r = run_command(
      cd + shell_quote(MESOROCK_ROCKFLOW) + " run perm/scene.toml --out flow --threads 1",
      tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary =
      nlohmann::json::parse(mesorock::test::read_file(tmp / "flow" / "summary.json"));
  EXPECT_GT(summary["solid"]["invariant"]["checks"].get<int>(), 1);
  EXPECT_EQ(summary["solid"]["invariant"]["inside_max"].get<int>(), 0);
  EXPECT_NE(mesorock::test::read_file(tmp / "flow" / "thermo.csv").find("solid_inside"),
            std::string::npos);
  r = run_command(cd + shell_quote(MESOROCK_ROCKFLOW) +
                      " sweep perm/scene.toml --out sweep --forces 0.02 --warmup 20"
                      " --block-steps 10 --window 2 --measure-blocks 2 --max-steps 200"
                      " --viscosity 7 --threads 1",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto sweep = nlohmann::json::parse(mesorock::test::read_file(tmp / "sweep" / "sweep.json"));
  EXPECT_EQ(sweep["flow_axis"], "x");
  EXPECT_EQ(sweep["driven_types"], nlohmann::json::array({"fluid"}));
  EXPECT_DOUBLE_EQ(sweep["fluid_density"].get<double>(), 6.5);
  EXPECT_EQ(sweep["fluid_particles"].get<std::int64_t>(), fluid);

  // Flow along y without the mirror: the block as it is, driven along y.
  r = run_command(cd + rockprep() +
                      " run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --flow-axis y"
                      " --no-mirror --all-pores --tiles " +
                      shell_quote(small_db().string()) + " --seed 5 --quiet --out perm_y",
                  tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const pipeline::Scene scene_y = pipeline::load_scene(tmp / "perm_y" / "scene.toml");
  EXPECT_DOUBLE_EQ(scene_y.box.hi[0], 20 * 0.5);
  EXPECT_DOUBLE_EQ(scene_y.box.hi[1], 16 * 0.5);
  ASSERT_EQ(scene_y.output.regions.size(), 1u);  // not mirrored: the block is the box
  EXPECT_EQ(scene_y.output.regions[0].name, "block");
  // Without --body-force the scene's flow stage takes the top suggested sweep force (3 digits),
  // so that `rockflow run` shows a flux above the noise whatever the resolution.
  const auto run_y = nlohmann::json::parse(mesorock::test::read_file(tmp / "perm_y" / "run.json"));
  const double median_y = run_y.at("pore_sizes").at("median_rc").get<double>();
  const double g_y = run_y.at("parameters").at("body_force").get<double>();
  EXPECT_EQ(run_y["parameters"]["body_force_from"], "median pore");
  EXPECT_NEAR(g_y * median_y * median_y, pipeline::prep::kSweepForceTimesPore2,
              0.006 * pipeline::prep::kSweepForceTimesPore2);
  EXPECT_EQ(scene_y.model.types[0].body_force, (std::array<double, 3>{0, g_y, 0}));
  // Every pore kept: no fluid in solid, no wall in a pore.
  const Placement placed_y =
      placement(sim::read_particle_file(tmp / "perm_y" / "particles.h5"), 0, false);
  EXPECT_GT(placed_y.fluid, 0);
  EXPECT_EQ(placed_y.misplaced_fluid, 0);
  EXPECT_EQ(placed_y.misplaced_wall, 0);
}

// Without a length scale, rockprep run reports the pore sizes and picks the rc per voxel that
// resolves them (pipeline/prep/stokes_regime.h); the permeability layout's walls take the no-slip
// fluid-wall A unless one is given.
TEST(PackingCli, RunPicksTheResolutionFromThePoreSizes) {
  TempDir tmp;
  make_stack(tmp);
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && ";
  // The tiles of the chosen voxel edge are built here: small ones, fast.
  CommandResult r = run_command(cd + rockprep() +
                                    " run syn/truth.mhd --layout permeability --tile-variants 100"
                                    " --tile-box-edge 4 --tile-relax-steps 100"
                                    " --tile-equilibrate-steps 1000 --tile-decorrelate-steps 100"
                                    " --threads 1 --relax-steps 10 --flow-steps 10 --out auto",
                                tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("no length scale given"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pore sizes (local thickness by pore volume)"), std::string::npos) << r.out;
  const auto run = nlohmann::json::parse(mesorock::test::read_file(tmp / "auto" / "run.json"));
  const double critical = run["pore_sizes"]["critical_rc"].get<double>();
  const double rpv = run["parameters"]["scale"]["rc_per_voxel"].get<double>();
  EXPECT_NEAR(rpv, pipeline::prep::auto_rc_per_voxel(critical / rpv), 1e-12);
  EXPECT_TRUE(critical >= pipeline::prep::kResolvedThroatRc - 1e-9 ||
              rpv == pipeline::prep::kMaxAutoRcPerVoxel)
      << critical << " rc at " << rpv << " rc per voxel";
  EXPECT_DOUBLE_EQ(run["parameters"]["pairs"]["a_inorganic"].get<double>(),
                   pipeline::prep::kNoSlipWallA);
  const pipeline::Scene scene = pipeline::load_scene(tmp / "auto" / "scene.toml");
  const int fluid = scene.model.type_index("fluid");
  for (int t = 0; t < scene.model.ntypes(); ++t)
    if (t != fluid) EXPECT_DOUBLE_EQ(scene.model.pair(fluid, t).A, pipeline::prep::kNoSlipWallA);
}

TEST(PackingCli, RunRefusesBadInputWithoutOutput) {
  TempDir tmp;
  make_stack(tmp);
  {
    // Solid with a closed pore: nothing joins the inlet and outlet faces.
    std::string v(512, '\3');
    for (int k : {4 * 64 + 4 * 8 + 3, 4 * 64 + 4 * 8 + 4}) v[static_cast<size_t>(k)] = '\1';
    std::ofstream(tmp / "closed.raw", std::ios::binary) << v;
    std::ofstream(tmp / "open.raw", std::ios::binary) << std::string(512, '\1');  // all pore
  }
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && " + rockprep();
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"run syn/truth.mhd --rc-per-voxel 0.5 --nm-per-rc 2 --out o", "length scale"},
      {"run syn/truth.mhd --rc-per-voxel -1 --out o", "must be positive"},
      {"run syn/truth.mhd --rc-per-voxel 0 --out o", "--rc-per-voxel: must be positive"},
      {"run syn/truth.mhd --nm-per-rc 0 --out o", "--nm-per-rc: must be positive"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --max-particles 100 --tiles " +
           shell_quote(small_db().string()) + " --out o",
       "max-particles"},
      {"run closed.raw --shape 8,8,8 --dtype uint8 --labels 1=pore,3=inorganic --rc-per-voxel "
       "0.5 --tiles " +
           shell_quote(small_db().string()) + " --out o",
       "no pore cluster joins"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --wall-thickness-rc 0.5 --out o", "thickness"},
      // Negative counts wrapped to 2^64 - 1 (issue 22), and --threads had no bound.
      {"run syn/truth.mhd --rc-per-voxel 0.5 --flow-steps -1 --out o", "--flow-steps"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --tile-variants 1e18 --out o", "--tile-variants"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --threads 100000 --out o", "--threads"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --crop 0:5,0:5,0:50 --out o", "syn/truth.mhd"},
      {"run syn/grey --rc-per-voxel 0.5 --out o", "not a phase-label volume"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --tiles syn/truth.raw --out o", "truth.raw"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --layout periodic --out o", "--layout"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --inlet-rc 3 --out o",
       "--inlet-rc belongs to --layout flooding"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --no-mirror --out o",
       "--no-mirror belongs to --layout permeability"},
      {"run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --body-force 0 --out o",
       "--body-force"},
      // A force that is not a number is refused like a non-positive one.
      {"run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --body-force nan --out o",
       "--body-force"},
      {"run closed.raw --shape 8,8,8 --dtype uint8 --labels 1=pore,3=inorganic --rc-per-voxel "
       "0.5 --layout permeability --tiles " +
           shell_quote(small_db().string()) + " --out o",
       "no pore cluster joins the block's faces along x"},
      {"run open.raw --shape 8,8,8 --dtype uint8 --labels 1=pore --rc-per-voxel 0.5 --layout "
       "permeability --tiles " +
           shell_quote(small_db().string()) + " --out o",
       "a sample without solid has no permeability"},
  };
  for (const Case& c : cases) {
    const CommandResult r = run_command(cd + " " + c.args, tmp.path());
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(tmp / "o")) << c.args;
    for (const auto& e : fs::directory_iterator(tmp.path()))  // .o.PID.partial
      EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << c.args;
  }
}

}  // namespace
// Issue 58: rockprep run takes the output lock before the load (item 1): a folder held by another
// process is refused at once naming it and the pid. An --out holding '"' or '\' (item 10) gave a
// scene.toml that rockflow could not parse: the name is escaped now. A usage error is one line
// without CLI11's 309-digit bound (item 16).
TEST(PackingCli, RunTakesTheFolderLockAndWritesAnyFolderNameIntoAValidScene) {
  TempDir tmp;
  make_stack(tmp);
  const std::string cd = "cd " + shell_quote(tmp.path().string()) + " && " + rockprep();
  const std::string run =
      " run syn/truth.mhd --rc-per-voxel 0.5 --layout permeability --wall-fill lattice"
      " --fluid-fill random --seed 5 --out ";
  {
    const mesorock::OutputLock held(tmp / "held");
    const CommandResult r = run_command(cd + run + "held", tmp.path());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("held: in use by another process (pid " + std::to_string(getpid())),
              std::string::npos)
        << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  const std::string odd = "we\"ird\\name";
  const CommandResult r = run_command(cd + run + shell_quote(odd), tmp.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const pipeline::Scene scene = pipeline::load_scene(tmp / odd / "scene.toml");
  EXPECT_EQ(scene.name, odd);
  EXPECT_FALSE(fs::exists(tmp / odd / mesorock::OutputLock::kFileName));
  const CommandResult usage =
      run_command(cd + " run syn/truth.mhd --threads -1 --out u", tmp.path());
  EXPECT_EQ(usage.exit_code, 2) << usage.err;
  EXPECT_EQ(usage.err.rfind("rockprep: error: --threads: ", 0), 0u) << usage.err;
  EXPECT_LT(usage.err.size(), 200u) << usage.err;
}

}  // namespace mesorock::packing
