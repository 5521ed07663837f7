#pragma once
// The tile database file (HDF5; layout in docs/packing.md):
//
//   / attributes: format ("mesorock tile database 1"), mesorock_version, git_commit
//   /tiles/set_000 ...: one group per tile set, with
//     datasets   offsets int64 [tiles + 1], position float64 [N, 3], velocity float64 [N, 3]
//     attributes the key (role, density, edge_xyz, A, B, rd, gamma, kBT, density_kernel), the
//                measurements (measured_density, temperature, temperature_error,
//                temperature_at_cuts, mean_count, count_std) and how it was built (seed,
//                relax_steps, equilibration_steps, decorrelation_steps, dt, box_xyz,
//                tiles_per_box_xyz, cuts, box_particles, seconds, backend, mesorock_version,
//                git_commit, provenance)
//
// The file is rewritten whole (temporary file, then rename) when a set is added, so a failed
// write never damages a database. Errors are IoError naming the file and the object.
#include <filesystem>
#include <optional>
#include <vector>

#include "tiledb/tile_set.h"

namespace mesorock::tiledb {

struct TileDatabase {
  std::vector<TileSet> sets;

  // The set whose key matches, or nullptr.
  const TileSet* find(const TileKey& key) const;
  // Adds `set`, replacing a set with a matching key (returns true when it replaced one).
  bool put(TileSet set);
};

TileDatabase read_tile_database(const std::filesystem::path& path);
void write_tile_database(const std::filesystem::path& path, const TileDatabase& db);

// The acceptance checks of one set (tiledb/check.cpp): the tiles' density within
// `density_tolerance` (relative) of the key's, the box temperature within
// `temperature_tolerance` of kBT, every particle inside its tile, offsets consistent, and the
// recorded measurements equal to what the data give.
struct TileCheckOptions {
  double density_tolerance = 0.01;
  double temperature_tolerance = 0.02;
};
struct TileCheck {
  bool pass = true;
  std::vector<std::string> problems;  // one line each
  double density_deviation = 0;       // measured / target - 1
  double temperature_deviation = 0;   // T / kBT - 1 (box, time average)
  std::string str() const;            // one line: "pass: density +0.01%, T -0.3%" or problems
};
TileCheck check_tile_set(const TileSet& set, const TileCheckOptions& options = {});

}  // namespace mesorock::tiledb
