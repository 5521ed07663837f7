#pragma once
// The D3Q19 velocity set of the lattice Boltzmann reference (docs/lbm.md): c_0 = 0, nine
// velocities c_1..c_9, and at q + 9 their opposites. The node body (node_update.h) writes the
// moments out for exactly this order; velocities_are_as_written() keeps the table and the body
// together.
#include <cstdint>
#include <limits>

#include "sim/hd.h"

namespace mesorock::lbm {

constexpr int kQ = 19;
constexpr int kHalf = 9;

// A link whose upstream node is solid (or not simulated): the population bounces back at the
// halfway wall.
constexpr std::uint32_t kWall = std::numeric_limits<std::uint32_t>::max();

// The "magic" TRT parameter (tau+ - 1/2)(tau- - 1/2): walls exactly half-way, k independent of tau.
constexpr double kMagicLambda = 3.0 / 16;

constexpr int kC[kQ][3] = {{0, 0, 0},   {1, 0, 0},  {0, 1, 0},   {0, 0, 1},   {1, 1, 0},
                           {1, -1, 0},  {1, 0, 1},  {1, 0, -1},  {0, 1, 1},   {0, 1, -1},
                           {-1, 0, 0},  {0, -1, 0}, {0, 0, -1},  {-1, -1, 0}, {-1, 1, 0},
                           {-1, 0, -1}, {-1, 0, 1}, {0, -1, -1}, {0, -1, 1}};

// Weights: 1/3 at rest, 1/18 along the axes (q = 1..3 and 10..12), 1/36 along the face diagonals.
MESO_HD constexpr double weight(int q) {
  return q == 0 ? 1.0 / 3 : ((q <= 3 || (q >= 10 && q <= 12)) ? 1.0 / 18 : 1.0 / 36);
}

MESO_HD constexpr int opposite(int q) {
  return q == 0 ? 0 : (q <= kHalf ? q + kHalf : q - kHalf);
}

constexpr bool velocities_are_as_written() {
  constexpr int expected[kHalf + 1][3] = {{0, 0, 0},  {1, 0, 0}, {0, 1, 0},  {0, 0, 1}, {1, 1, 0},
                                          {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}};
  for (int q = 0; q <= kHalf; ++q)
    for (int a = 0; a < 3; ++a) {
      if (kC[q][a] != expected[q][a]) return false;
      if (q > 0 && kC[q + kHalf][a] != -expected[q][a]) return false;
    }
  double sum = 0;
  for (int q = 0; q < kQ; ++q) {
    const int c2 = kC[q][0] * kC[q][0] + kC[q][1] * kC[q][1] + kC[q][2] * kC[q][2];
    if (weight(q) != (c2 == 0 ? 1.0 / 3 : (c2 == 1 ? 1.0 / 18 : 1.0 / 36))) return false;
    sum += weight(q);
  }
  return sum > 1 - 1e-15 && sum < 1 + 1e-15;
}
static_assert(velocities_are_as_written(), "lbm/d3q19.h: the node body assumes this kC");

}  // namespace mesorock::lbm
