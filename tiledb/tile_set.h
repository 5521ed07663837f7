#pragma once
// The tile database's data: sets of particle tiles cut from periodic boxes equilibrated with the
// embedded solver (tiledb/generate.h), keyed by what they were equilibrated with and the shape
// of the voxel they fill. The 2020 paper fills each surface-wall voxel with a locally
// equilibrated particle arrangement drawn at random from such a database instead of a lattice,
// which avoids the lattice's near-wall temperature artefacts (docs/packing.md).
//
// Coordinates here are the solver's (x, y, z), in rc. A tile's particle positions are relative
// to the tile's lower corner and lie in [0, edge) on every axis.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/model.h"

namespace mesorock::tiledb {

enum class TileRole { Wall, Fluid };
const char* to_string(TileRole role);          // "wall", "fluid"
TileRole parse_tile_role(const std::string&);  // throws ConfigError

// What a tile set was equilibrated with: the key a packing looks its tiles up by. The particles
// interact among themselves with one mDPD pair set (for walls: the wall-wall set).
struct TileKey {
  TileRole role = TileRole::Wall;
  double density = 8.0;                       // target number density, rc^-3
  std::array<double, 3> edge{0.5, 0.5, 0.5};  // tile edges (x, y, z) in rc: the voxel's
  double A = -40.0, B = 25.0, rd = 0.75, gamma = 4.5, kBT = 1.0;
  sim::DensityKernelKind density_kernel = sim::DensityKernelKind::Warren;

  // "wall, rho 8, tile 0.5 x 0.5 x 0.5 rc, A -40 B 25 rd 0.75 gamma 4.5 kBT 1 (warren)"
  std::string str() const;
  // Same role and kernel, and every number equal to a relative 1e-9 (voxel edges computed from
  // a spacing and a length scale come out with round-off).
  bool matches(const TileKey& other) const;
  // Throws ConfigError naming the problem (density, edges, rd, kBT must be positive...).
  void validate() const;
};

// How a tile set was made (recorded in the database with the data).
struct TileBuildRecord {
  std::uint64_t seed = 1;
  std::uint64_t relax_steps = 0;          // at dt / 5 from random positions
  std::uint64_t equilibration_steps = 0;  // at dt before the first cut
  std::uint64_t decorrelation_steps = 0;  // between cuts
  double dt = 0.01;
  std::array<double, 3> box{0, 0, 0};  // the periodic box's edges (whole tiles per axis)
  std::array<int, 3> tiles_per_box{0, 0, 0};
  int cuts = 0;  // snapshots cut into tiles
  std::int64_t box_particles = 0;
  double seconds = 0;
  std::string backend;
  std::string mesorock_version, git_commit;
  std::string provenance_json;  // the command that built it, as JSON text
};

// What the tiles measure (recorded, and re-checked by check_tile_set).
struct TileSetStats {
  double density = 0;            // particles in all tiles / their total volume
  double temperature = 0;        // kinetic temperature of the box, time average over the cuts' span
  double temperature_error = 0;  // one standard error (block averages)
  double temperature_at_cuts = 0;  // kinetic temperature of the tiles' own velocities
  double mean_count = 0;           // particles per tile
  double count_std = 0;            // standard deviation of the particles per tile
};

struct TileSet {
  TileKey key;
  std::vector<std::int64_t> offsets{0};  // tile t holds particles [offsets[t], offsets[t + 1])
  std::vector<double> position;          // 3 per particle, relative to the tile's corner
  std::vector<double> velocity;          // 3 per particle, from the equilibrated box
  TileSetStats stats;
  TileBuildRecord build;

  std::size_t tiles() const { return offsets.size() - 1; }
  std::size_t particles() const { return position.size() / 3; }
  double tile_volume() const { return key.edge[0] * key.edge[1] * key.edge[2]; }
  std::size_t bytes() const;
};

// Recomputes density, temperature_at_cuts, mean_count and count_std from the data.
void measure_tiles(TileSet& set);

}  // namespace mesorock::tiledb
