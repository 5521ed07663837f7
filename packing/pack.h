#pragma once
// Voxels to particles, streaming: a volume of role codes (one byte per voxel: 0 = nothing, k =
// roles[k - 1]) is turned into particles a few z-layers at a time and handed to a sink, so memory
// follows the particles of those layers, never the whole box (the 2020 paper: filling the box
// first "could be over 100 times higher than it may be eventually required").
//
// How a role fills its voxels:
// * tiles: a tile drawn at random from a tile set (tiledb) under a random symmetry of the voxel's
//   shape, both a function of (seed, voxel index) only: the 2020 paper's locally equilibrated
//   packing. Velocities: the tile's (transformed by the symmetry) when the role is thermal.
// * lattice: the sites of one simple cubic lattice of spacing density^(-1/3) over the whole
//   volume (sites at (i + 1/2) a from the volume's corner) that fall in the voxel: the
//   "lattice-like" packing the paper replaced, kept for comparison.
// * random: floor(lambda) or floor(lambda) + 1 particles (lambda = density x voxel volume; the
//   extra one with probability frac(lambda)) at uniform positions; Maxwell velocities at kBT
//   when thermal.
// Every particle lies inside its voxel (round-off at the faces is clamped inwards), and ids run
// from first_id in the order of the voxels (z, y, x), so the result does not depend on the
// thread count.
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "packing/sink.h"
#include "tiledb/tile_set.h"
#include "voxel/volume.h"

namespace mesorock::packing {

enum class Fill { Tiles, Lattice, Random };
const char* to_string(Fill fill);          // "tiles", "lattice", "random"
Fill parse_fill(const std::string& name);  // throws ConfigError

struct RoleSpec {
  std::string name;       // for reports, e.g. "inorganic wall"
  std::int32_t type = 0;  // particle type index
  Fill fill = Fill::Random;
  double density = 0;  // lattice and random; for tiles the set's density is used
  const tiledb::TileSet* tiles = nullptr;  // Fill::Tiles
  bool thermal = false;                    // mobile particles get velocities; otherwise at rest
  double kBT = 1.0;                        // random + thermal: Maxwell temperature
};

struct PackOptions {
  std::array<double, 3> voxel_rc{0.5, 0.5, 0.5};  // voxel edges (x, y, z) in rc
  std::array<double, 3> origin{0, 0, 0};          // (x, y, z) of the corner of voxel (0, 0, 0)
  std::uint64_t seed = 1;
  std::int64_t first_id = 0;
  std::size_t chunk_particles = 1 << 20;      // particles per sink append (about)
  std::function<void(double done)> progress;  // fraction of layers done, now and then
};

struct RoleCount {
  std::int64_t voxels = 0;
  std::int64_t particles = 0;
  double expected = 0;  // density x voxels x voxel volume
  // Sum over voxels of the variance of the voxel's count: tiles, the set's count variance;
  // random, frac (1 - frac); lattice, 0 (deterministic).
  double variance = 0;
};

struct PackStats {
  std::vector<RoleCount> roles;  // per role
  std::int64_t particles = 0;
  std::int64_t voxels_filled = 0;
  std::size_t peak_buffer_bytes = 0;  // largest amount of particle data held at once
  double seconds = 0;
};

// Bytes one particle takes in a ParticleSet (and in a particle file): 6 doubles, int32, int64.
constexpr std::size_t kParticleBytes =
    6 * sizeof(double) + sizeof(std::int32_t) + sizeof(std::int64_t);

// `codes` is a uint8 volume (z, y, x). Throws ConfigError for a code without a role, a role
// without tiles or density, or tiles whose edges are not the voxel's.
PackStats pack_voxels(const voxel::Volume& codes, const std::vector<RoleSpec>& roles,
                      const PackOptions& options, ParticleSink& sink);

}  // namespace mesorock::packing
