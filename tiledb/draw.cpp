#include "tiledb/draw.h"

#include <algorithm>
#include <cmath>

#include "sim/init.h"

namespace mesorock::tiledb {

std::vector<Symmetry> box_symmetries(const std::array<double, 3>& edge) {
  auto equal = [&](int a, int b) {
    const double x = edge[static_cast<std::size_t>(a)], y = edge[static_cast<std::size_t>(b)];
    return std::abs(x - y) <= 1e-9 * std::max(x, y);
  };
  std::vector<Symmetry> out;
  std::array<int, 3> perm{0, 1, 2};
  do {
    bool allowed = true;
    for (int a = 0; a < 3; ++a) allowed = allowed && equal(a, perm[static_cast<std::size_t>(a)]);
    if (!allowed) continue;
    for (int mask = 0; mask < 8; ++mask) {
      Symmetry s;
      s.perm = perm;
      for (int a = 0; a < 3; ++a) s.flip[static_cast<std::size_t>(a)] = (mask >> a) & 1;
      out.push_back(s);
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return out;
}

namespace {
constexpr std::uint64_t kStreamDraw = 0x74696c65;  // "tile"
}

TileDraw draw_tile(std::uint64_t seed, std::uint64_t voxel, std::size_t tiles,
                   std::size_t symmetries) {
  TileDraw d;
  const double u = sim::seeded_uniform(seed, kStreamDraw, voxel, 0);
  const double w = sim::seeded_uniform(seed, kStreamDraw, voxel, 1);
  d.tile = std::min(tiles - 1, static_cast<std::size_t>(u * static_cast<double>(tiles)));
  d.symmetry =
      std::min(symmetries - 1, static_cast<std::size_t>(w * static_cast<double>(symmetries)));
  return d;
}

}  // namespace mesorock::tiledb
