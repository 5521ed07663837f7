#include "pipeline/prep/packing_common.h"

#include <sys/resource.h>

#include <cstdio>
#include <iostream>
#include <sstream>

#include "mesorock/cache.h"
#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "pipeline/prep/common.h"

namespace mesorock::pipeline::prep {

std::array<double, 3> parse_voxel_rc(const std::string& text, const std::string& option) {
  const std::vector<double> v = parse_numbers(text, option);
  if (v.size() != 3) throw ConfigError(option + ": expected DZ,DY,DX in rc, got '" + text + "'");
  for (double d : v)
    if (!(d > 0)) throw ConfigError(option + ": voxel edges must be positive ('" + text + "')");
  return {v[2], v[1], v[0]};
}

double default_density(tiledb::TileRole role) {
  return role == tiledb::TileRole::Wall ? 8.0 : 6.5;
}

void TileInteractionArgs::add_to(CLI::App* app, const std::string& prefix) {
  const std::string p = prefix.empty() ? "--" : "--" + prefix + "-";
  app->add_option(p + "A", A, "Tiles' pair set: attraction A (default -40)");
  app->add_option(p + "B", B, "Tiles' pair set: many-body repulsion B (default 25)");
  app->add_option(p + "rd", rd, "Tiles' pair set: many-body cutoff rd (default 0.75)");
  app->add_option(p + "gamma", gamma, "Tiles' pair set: dissipation gamma (default 4.5)");
  app->add_option(p + "kbt", kBT, "Tiles' temperature kBT (default 1)");
  app->add_option(p + "density-kernel", density_kernel, "warren (default) or lucy")
      ->check(CLI::IsMember({"warren", "lucy"}));
}

void TileInteractionArgs::apply_to(tiledb::TileKey& key) const {
  key.A = A;
  key.B = B;
  key.rd = rd;
  key.gamma = gamma;
  key.kBT = kBT;
  key.density_kernel =
      density_kernel == "lucy" ? sim::DensityKernelKind::Lucy : sim::DensityKernelKind::Warren;
}

void TileGenerationArgs::add_to(CLI::App* app, const std::string& prefix) {
  const std::string p = "--" + prefix;
  app->add_option(p + "variants", variants,
                  "Tiles per set, at least (whole snapshots are kept; default 1024)");
  app->add_option(p + "box-edge", box_edge,
                  "Equilibration box edge, rc (rounded up to whole tiles; default 6)");
  app->add_option(p + "relax-steps", relax,
                  "Tiles: relaxation steps at dt/5 from random positions (default 200)");
  app->add_option(p + "equilibrate-steps", equilibrate,
                  "Tiles: equilibration steps before the first cut (default 2000)");
  app->add_option(p + "decorrelate-steps", decorrelate, "Tiles: steps between cuts (default 500)");
  app->add_option(p + "dt", dt, "Tiles: time step of the equilibration (default 0.01)");
  app->add_option(p + "seed", seed, "Tiles: seed of the tile generation (default 1)");
  app->add_option(p + "backend", backend,
                  "Tiles: solver backend, auto (the GPU when present), cpu or cuda (default auto)")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}));
  app->add_option("--threads", threads,
                  "CPU threads of the solver and the packing (default: all cores)")
      ->check(CLI::NonNegativeNumber);
}

sim::BackendKind TileGenerationArgs::resolved_backend() const {
  if (backend == "cpu") return sim::BackendKind::CPU;
  if (backend == "cuda") return sim::BackendKind::CUDA;
  if (backend != "auto")
    throw ConfigError("tiles: backend must be auto, cpu or cuda (got '" + backend + "')");
  // Asked once: the answer does not change while the process runs.
  static const bool device = sim::cuda_unavailable_reason().empty();
  return device ? sim::BackendKind::CUDA : sim::BackendKind::CPU;
}

tiledb::TileBuildOptions TileGenerationArgs::options(const std::string& provenance_json) const {
  tiledb::TileBuildOptions o;
  o.variants = variants;
  o.min_box_edge = box_edge;
  o.relax_steps = relax;
  o.equilibration_steps = equilibrate;
  o.decorrelation_steps = decorrelate;
  o.dt = dt;
  o.seed = seed;
  o.sim.threads = threads;
  o.sim.backend = resolved_backend();
  o.provenance_json = provenance_json;
  return o;
}

std::string tile_cache_key(const tiledb::TileKey& key, const TileGenerationArgs& g) {
  // Nine significant digits: voxel edges computed from a spacing differ only in round-off.
  auto n = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", v);
    return std::string(b);
  };
  std::ostringstream s;
  s << "tiles|mesorock " << kVersion << "|" << tiledb::to_string(key.role) << "|rho "
    << n(key.density) << "|edge " << n(key.edge[0]) << " " << n(key.edge[1]) << " "
    << n(key.edge[2]) << "|A " << n(key.A) << "|B " << n(key.B) << "|rd " << n(key.rd) << "|gamma "
    << n(key.gamma) << "|kBT " << n(key.kBT) << "|" << sim::to_string(key.density_kernel)
    << "|variants " << g.variants << "|box " << n(g.box_edge) << "|relax " << g.relax
    << "|equilibrate " << g.equilibrate << "|decorrelate " << g.decorrelate << "|dt " << n(g.dt)
    << "|seed " << g.seed << "|backend " << sim::to_string(g.resolved_backend());
  return s.str();
}

std::filesystem::path tile_cache_file(const std::filesystem::path& cache_dir,
                                      const tiledb::TileKey& key, const TileGenerationArgs& g) {
  char name[40];
  std::snprintf(name, sizeof name, "tiles-%016llx.h5",
                static_cast<unsigned long long>(fnv1a(tile_cache_key(key, g))));
  return cache_dir / name;
}

const char* to_string(TileSource s) {
  switch (s) {
    case TileSource::Database:
      return "database";
    case TileSource::Cache:
      return "cache";
    case TileSource::Built:
      return "built";
  }
  return "?";
}

const tiledb::TileSet& find_or_build_tiles(tiledb::TileDatabase& db, const tiledb::TileKey& key,
                                           const TileGenerationArgs& generation,
                                           const std::string& provenance_json,
                                           const std::function<void(const std::string&)>& say,
                                           TileSource* source,
                                           const std::filesystem::path& cache_dir) {
  namespace fs = std::filesystem;
  if (const tiledb::TileSet* s = db.find(key)) {
    if (source) *source = TileSource::Database;
    return *s;
  }
  const fs::path cached =
      cache_dir.empty() ? fs::path() : tile_cache_file(cache_dir, key, generation);
  std::error_code ec;
  if (!cached.empty() && fs::exists(cached, ec)) {
    try {
      const tiledb::TileDatabase c = tiledb::read_tile_database(cached);
      // The file holds the set's key: a hash collision or another key is a miss.
      if (c.sets.size() == 1 && c.sets.front().key.matches(key)) {
        db.put(c.sets.front());
        if (say) say("  from the tile cache: " + cached.string());
        if (source) *source = TileSource::Cache;
        return *db.find(key);
      }
    } catch (const IoError& e) {
      if (say) say(std::string("  the cached set is unreadable, building it again: ") + e.what());
    }
  }
  tiledb::TileBuildOptions o = generation.options(provenance_json);
  o.progress = say;
  tiledb::TileSet set = tiledb::build_tile_set(key, o);
  const tiledb::TileCheck check = tiledb::check_tile_set(set);
  if (!check.pass)
    throw NumericalError("tiles " + key.str() + " failed their check: " + check.str());
  if (say) say("  check: " + check.str());
  if (!cached.empty()) {
    try {
      fs::create_directories(cache_dir, ec);
      if (ec) throw IoError(cache_dir.string() + ": cannot create the tile cache: " + ec.message());
      tiledb::TileDatabase one;
      one.put(set);
      tiledb::write_tile_database(cached, one);  // atomic: temporary name, then rename
      if (say) say("  saved to the tile cache: " + cached.string());
    } catch (const IoError& e) {
      std::cerr << "rockprep: warning: the tile set was not cached: " << e.what() << "\n";
    }
  }
  db.put(std::move(set));
  if (source) *source = TileSource::Built;
  return *db.find(key);
}

std::size_t peak_rss_bytes() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<std::size_t>(u.ru_maxrss) * 1024;
}

}  // namespace mesorock::pipeline::prep
