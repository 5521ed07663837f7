// rockprep tiles build|list|check: the tile database (tiledb/, docs/packing.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/exit_codes.h"
#include "pipeline/prep/common.h"
#include "pipeline/prep/packing_common.h"
#include "tiledb/database.h"
#include "tiledb/generate.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

struct TilesBuildArgs {
  std::string db;
  std::string role = "wall";
  double density = 0;  // 0: 8 for walls, 6.5 for fluid
  std::string voxel_rc = "0.5,0.5,0.5";
  TileInteractionArgs interaction;
  TileGenerationArgs generation;
  bool quiet = false;
};

struct TilesFileArgs {
  std::string db;
  bool json = false;
};

int run_tiles_build(const TilesBuildArgs& a) {
  tiledb::TileKey key;
  key.role = tiledb::parse_tile_role(a.role);
  key.density = a.density > 0 ? a.density : default_density(key.role);
  key.edge = parse_voxel_rc(a.voxel_rc, "--voxel-rc");
  a.interaction.apply_to(key);
  key.validate();
  const fs::path path(a.db);
  if (!path.parent_path().empty() && !fs::is_directory(path.parent_path()))
    throw IoError(a.db + ": parent folder does not exist");
  // Read an existing database first: a damaged one is reported before an hour of equilibration.
  tiledb::TileDatabase db;
  if (fs::exists(path)) db = tiledb::read_tile_database(path);

  Progress progress(a.quiet);
  nlohmann::json record = provenance("tiles build");
  tiledb::TileBuildOptions o = a.generation.options(record.dump());
  o.progress = [&](const std::string& line) { progress.note(line); };
  tiledb::TileSet set = tiledb::build_tile_set(key, o);
  const tiledb::TileCheck check = tiledb::check_tile_set(set);
  progress.note("check: " + check.str());
  const bool replaced = db.put(std::move(set));
  progress.stage("write " + a.db, 0, [&] { tiledb::write_tile_database(path, db); });
  progress.note(std::string(replaced ? "replaced" : "added") + " the set; " + a.db + " holds " +
                std::to_string(db.sets.size()) + " set" + (db.sets.size() == 1 ? "" : "s"));
  return check.pass ? kExitOk : kExitFailed;
}

nlohmann::json set_record(const tiledb::TileSet& s, const tiledb::TileCheck& c) {
  const tiledb::TileKey& k = s.key;
  return {{"name", k.str()},
          {"role", tiledb::to_string(k.role)},
          {"density", k.density},
          {"edge_xyz", k.edge},
          {"A", k.A},
          {"B", k.B},
          {"rd", k.rd},
          {"gamma", k.gamma},
          {"kBT", k.kBT},
          {"density_kernel", sim::to_string(k.density_kernel)},
          {"tiles", s.tiles()},
          {"particles", s.particles()},
          {"measured_density", s.stats.density},
          {"temperature", s.stats.temperature},
          {"temperature_error", s.stats.temperature_error},
          {"temperature_at_cuts", s.stats.temperature_at_cuts},
          {"particles_per_tile", {{"mean", s.stats.mean_count}, {"std", s.stats.count_std}}},
          {"build",
           {{"seed", s.build.seed},
            {"relax_steps", s.build.relax_steps},
            {"equilibration_steps", s.build.equilibration_steps},
            {"decorrelation_steps", s.build.decorrelation_steps},
            {"dt", s.build.dt},
            {"box_xyz", s.build.box},
            {"tiles_per_box_xyz", s.build.tiles_per_box},
            {"cuts", s.build.cuts},
            {"box_particles", s.build.box_particles},
            {"seconds", s.build.seconds},
            {"backend", s.build.backend},
            {"mesorock_version", s.build.mesorock_version},
            {"git_commit", s.build.git_commit}}},
          {"check", {{"pass", c.pass}, {"problems", c.problems}}}};
}

int run_tiles_list(const TilesFileArgs& a, bool check_only) {
  const tiledb::TileDatabase db = tiledb::read_tile_database(a.db);
  bool all = true;
  nlohmann::json sets = nlohmann::json::array();
  for (std::size_t k = 0; k < db.sets.size(); ++k) {
    const tiledb::TileSet& s = db.sets[k];
    const tiledb::TileCheck c = tiledb::check_tile_set(s);
    all = all && c.pass;
    if (a.json) {
      sets.push_back(set_record(s, c));
      continue;
    }
    char line[512];
    if (check_only) {
      std::snprintf(line, sizeof line, "set_%03zu %s: %s\n", k, s.key.str().c_str(),
                    c.str().c_str());
    } else {
      std::snprintf(line, sizeof line,
                    "set_%03zu %s\n  %zu tiles, %zu particles (%.3g +- %.3g per tile); density "
                    "%.6g; T %.4f +- %.4f; seed %llu, %llu + %llu steps, %d cut%s of a %.4g x "
                    "%.4g x %.4g box (%lld particles), %.1f s on %s; %s\n",
                    k, s.key.str().c_str(), s.tiles(), s.particles(), s.stats.mean_count,
                    s.stats.count_std, s.stats.density, s.stats.temperature,
                    s.stats.temperature_error, static_cast<unsigned long long>(s.build.seed),
                    static_cast<unsigned long long>(s.build.relax_steps),
                    static_cast<unsigned long long>(s.build.equilibration_steps), s.build.cuts,
                    s.build.cuts == 1 ? "" : "s", s.build.box[0], s.build.box[1], s.build.box[2],
                    static_cast<long long>(s.build.box_particles), s.build.seconds,
                    s.build.backend.c_str(), c.str().c_str());
    }
    std::cout << line;
  }
  if (a.json) {
    std::cout << nlohmann::json{{"database", a.db}, {"sets", sets}, {"pass", all}}.dump(2) << "\n";
  } else if (db.sets.empty()) {
    std::cout << a.db << ": no tile sets\n";
  }
  return check_only && !all ? kExitFailed : kExitOk;
}

}  // namespace

Command add_tiles_command(CLI::App& rockprep) {
  CLI::App* app = rockprep.add_subcommand(
      "tiles",
      "The tile database: equilibrated particle tiles for packing walls and fluid (build, list, "
      "check)");
  app->require_subcommand(1);
  auto build = std::make_shared<TilesBuildArgs>();
  CLI::App* b = app->add_subcommand(
      "build",
      "Equilibrate a periodic box with the embedded solver and cut it into voxel-shaped tiles; "
      "adds the set to DB (created when missing; a set with the same key is replaced)");
  b->add_option("db", build->db, "Tile database file (HDF5)")->required();
  b->add_option("--role", build->role, "wall (frozen after packing) or fluid (default wall)")
      ->check(CLI::IsMember({"wall", "fluid"}));
  b->add_option("--density", build->density, "Number density, rc^-3 (default 8 wall, 6.5 fluid)");
  b->add_option("--voxel-rc", build->voxel_rc,
                "Tile (voxel) edges DZ,DY,DX in rc, the order of --spacing (default 0.5,0.5,0.5)");
  build->interaction.add_to(b);
  build->generation.add_to(b);
  b->add_flag("--quiet", build->quiet, "No progress lines");

  auto list = std::make_shared<TilesFileArgs>();
  CLI::App* l = app->add_subcommand("list",
                                    "Print every tile set with its key, measurements and "
                                    "provenance");
  l->add_option("db", list->db, "Tile database file")->required();
  l->add_flag("--json", list->json, "One JSON object");
  auto check = std::make_shared<TilesFileArgs>();
  CLI::App* c = app->add_subcommand(
      "check",
      "Check every set: density within 1% of its target, temperature within 2% of kBT, every "
      "particle inside its tile; exit code 1 when a set fails");
  c->add_option("db", check->db, "Tile database file")->required();
  c->add_flag("--json", check->json, "One JSON object");

  return {app, [=] {
            if (b->parsed()) return run_tiles_build(*build);
            if (l->parsed()) return run_tiles_list(*list, false);
            return run_tiles_list(*check, true);
          }};
}

}  // namespace mesorock::pipeline::prep
