#pragma once
// Options and helpers the particle commands share (tiles, run, validate): the tile key's
// interaction set, how tile sets are generated, and voxel edges in rc.
#include <CLI/CLI.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "sim/simulation.h"
#include "tiledb/database.h"
#include "tiledb/generate.h"

namespace mesorock::pipeline::prep {

// "DZ,DY,DX" (the order of --spacing) in rc -> edges (x, y, z); ConfigError naming `option`.
std::array<double, 3> parse_voxel_rc(const std::string& text, const std::string& option);

// 8 for walls (the papers' wall density), 6.5 for fluid (a homogeneous A = -40 liquid: it
// coexists with vapour at 6.07).
double default_density(tiledb::TileRole role);

// The mDPD pair set the tiles are equilibrated with.
struct TileInteractionArgs {
  double A = -40, B = 25, rd = 0.75, gamma = 4.5, kBT = 1.0;
  std::string density_kernel = "warren";
  void add_to(CLI::App* app, const std::string& prefix = "");
  void apply_to(tiledb::TileKey& key) const;
};

// How tile sets are generated.
struct TileGenerationArgs {
  std::size_t variants = 1024;
  double box_edge = 6.0;
  std::uint64_t relax = 200, equilibrate = 2000, decorrelate = 500;
  double dt = 0.01;
  std::uint64_t seed = 1;
  int threads = 0;
  // The solver of the build: "auto" (the GPU when this build has CUDA and a device, else the
  // CPU), "cpu" or "cuda". Tiles built on either are the same physics but differ at round-off.
  std::string backend = "auto";
  sim::BackendKind resolved_backend() const;
  // Options --variants, --box-edge, --relax-steps, ... with `prefix` after the dashes ("tile-"
  // where the command has options of its own by those names), and --threads.
  void add_to(CLI::App* app, const std::string& prefix = "");
  tiledb::TileBuildOptions options(const std::string& provenance_json) const;
};

// The shared tile cache (docs/packing.md, "Tile cache"): one tile database per set in
// `cache_dir`, named by a hash of everything that decides its tiles (the key, the generation
// options but the thread count, which changes no tile, the backend, which changes them at
// round-off, and the mesorock version).
std::string tile_cache_key(const tiledb::TileKey& key, const TileGenerationArgs& generation);
std::filesystem::path tile_cache_file(const std::filesystem::path& cache_dir,
                                      const tiledb::TileKey& key,
                                      const TileGenerationArgs& generation);

// Where a set came from: the database given, the shared cache, or built here.
enum class TileSource { Database, Cache, Built };
const char* to_string(TileSource s);

// The set with `key` from `db`; else from the cache (when `cache_dir` is not empty); else built.
// A set built here is added to db and saved to the cache (a failed save is a warning: the run
// does not need it). `source` tells which.
const tiledb::TileSet& find_or_build_tiles(tiledb::TileDatabase& db, const tiledb::TileKey& key,
                                           const TileGenerationArgs& generation,
                                           const std::string& provenance_json,
                                           const std::function<void(const std::string&)>& say,
                                           TileSource* source,
                                           const std::filesystem::path& cache_dir = {});

// Peak resident memory of this process so far (getrusage), bytes.
std::size_t peak_rss_bytes();

}  // namespace mesorock::pipeline::prep
