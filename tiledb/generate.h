#pragma once
// Making tile sets with the embedded solver: a periodic box whose edges are whole numbers of
// tiles is filled at random at the key's density, relaxed, equilibrated with the key's pair set
// at kBT, and then cut into tiles at a few snapshots a decorrelation time apart. Every particle
// of a snapshot lands in exactly one tile (the cut grid is shifted by a random offset and wraps
// periodically), so the tiles' mean density is the box's, and each tile is a piece of an
// equilibrated liquid, whatever its size relative to rc.
#include <cstdint>
#include <functional>
#include <string>

#include "sim/simulation.h"
#include "tiledb/tile_set.h"

namespace mesorock::tiledb {

struct TileBuildOptions {
  std::size_t variants = 1024;  // at least this many tiles (whole snapshots are kept)
  double min_box_edge = 6.0;    // rc; the box is the smallest whole number of tiles at least this
  std::uint64_t relax_steps = 200;  // at dt / 5, from random positions
  std::uint64_t equilibration_steps = 2000;
  std::uint64_t decorrelation_steps = 500;
  double dt = 0.01;
  std::uint64_t seed = 1;
  sim::SimulationOptions sim;                        // backend and threads
  std::string provenance_json = "{}";                // recorded with the set
  std::function<void(const std::string&)> progress;  // progress lines (may be empty)
};

// Throws ConfigError for an invalid key or options (e.g. a box over 2,000,000 particles).
TileSet build_tile_set(const TileKey& key, const TileBuildOptions& options);

}  // namespace mesorock::tiledb
