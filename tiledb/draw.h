#pragma once
// Reproducible tile draws: which tile of a set fills a voxel, and under which symmetry of the
// voxel's shape. Every draw is a pure function of (seed, voxel index), through the solver's
// counter-based generator, so a packing gives the same particles for any thread count and any
// order in which voxels are visited.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tiledb/tile_set.h"

namespace mesorock::tiledb {

// A symmetry of a box with edges e (x, y, z): local coordinate a of the image is coordinate
// perm[a] of the original, mirrored (e[a] - u) when flip[a]. A permutation may only exchange
// axes of equal length, so the image fills the same box.
struct Symmetry {
  std::array<int, 3> perm{0, 1, 2};
  std::array<bool, 3> flip{false, false, false};
};

// Every symmetry the box allows: the 8 mirror combinations times the permutations of equal
// edges (48 for a cube, 16 with two equal edges, 8 with none). Edges equal to a relative 1e-9
// count as equal. The identity comes first.
std::vector<Symmetry> box_symmetries(const std::array<double, 3>& edge);

// Image of a point u in [0, e) and of a velocity v under the symmetry.
inline std::array<double, 3> apply_to_position(const Symmetry& s, const std::array<double, 3>& e,
                                               const double* u) {
  std::array<double, 3> r{};
  for (int a = 0; a < 3; ++a) {
    const double w = u[s.perm[static_cast<std::size_t>(a)]];
    r[static_cast<std::size_t>(a)] =
        s.flip[static_cast<std::size_t>(a)] ? e[static_cast<std::size_t>(a)] - w : w;
  }
  return r;
}
inline std::array<double, 3> apply_to_velocity(const Symmetry& s, const double* v) {
  std::array<double, 3> r{};
  for (int a = 0; a < 3; ++a) {
    const double w = v[s.perm[static_cast<std::size_t>(a)]];
    r[static_cast<std::size_t>(a)] = s.flip[static_cast<std::size_t>(a)] ? -w : w;
  }
  return r;
}

struct TileDraw {
  std::size_t tile = 0;
  std::size_t symmetry = 0;
};

// The tile (of `tiles`) and symmetry (of `symmetries`) for voxel `voxel`, from `seed`.
TileDraw draw_tile(std::uint64_t seed, std::uint64_t voxel, std::size_t tiles,
                   std::size_t symmetries);

}  // namespace mesorock::tiledb
