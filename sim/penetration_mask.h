#pragma once
// Where the frozen wall particles alone may put a point inside the wall (phi > phi_c of the wall
// model, sim/wall_model.h): one bit per cell of a fine grid over the box, set where an upper
// bound of phi over the whole cell passes phi_c less a margin.
//
// Why: the GPU's corrector before the sort computes phi over the frozen part for every mobile
// particle, and at the resolutions rockprep picks most of the fluid has wall within rc (73% at
// 0.5 rc per voxel), so that scan cost 0.46 ms of a 3.5 ms step (docs/benchmarks.md). A particle
// in a clear cell has phi <= phi_c for certain: the scan would decide "no correction", so it is
// skipped and every result keeps its bits. Only the frozen part enters the bound, as only the
// frozen part enters that scan (Parts::FrozenOnly).
//
// The bound of a cell B: phi(p) = (1 / n_w) sum_j W(|p - x_j|) with W decreasing, so for every p
// in B, phi(p) <= (1 / n_w) sum_j W(dist(x_j, B)), dist the distance from x_j to the box B
// (0 inside). Periodic images may be counted more than once; that only raises the bound.
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "sim/hd.h"

namespace mesorock::sim {

template <class Real>
struct PenetrationMask {
  // 32 cells along x per word; dims[0] is a multiple of 32. Null: no mask, every particle is
  // scanned.
  const std::uint32_t* bits = nullptr;
  Real lo[3] = {0, 0, 0};
  Real cell[3] = {1, 1, 1};
  Real inv_cell[3] = {1, 1, 1};
  int dims[3] = {0, 0, 0};

  static constexpr int kCellsPerWord = 32;
  // The cell box is widened by this much (rc) in the bound, so that a point the rounding of
  // (p - lo) / cell files in a neighbouring cell is still covered.
  static constexpr double kRoundingMargin = 1e-3;
  // A cell's bit is set where its bound passes phi_c - kPhiMargin: the bound and the scan round
  // their sums differently.
  static constexpr double kPhiMargin = 1e-3;

  MESO_HD MESO_INLINE bool enabled() const { return bits != nullptr; }
  MESO_HD MESO_INLINE std::size_t words() const {
    return static_cast<std::size_t>(dims[0] / kCellsPerWord) * static_cast<std::size_t>(dims[1]) *
           static_cast<std::size_t>(dims[2]);
  }

  // Whether phi may pass phi_c at (x, y, z): true without a mask, outside the mask's grid (a
  // position beyond a wall face of the box, or NaN) and in a set cell.
  MESO_HD MESO_INLINE bool may_exceed(Real x, Real y, Real z) const {
    if (!bits) return true;
    const Real p[3] = {x, y, z};
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const Real u = (p[a] - lo[a]) * inv_cell[a];
      if (!(u >= Real(0)) || !(u < Real(dims[a]))) return true;
      c[a] = static_cast<int>(u);
    }
    const std::size_t index = (static_cast<std::size_t>(c[2]) * static_cast<std::size_t>(dims[1]) +
                               static_cast<std::size_t>(c[1])) *
                                  static_cast<std::size_t>(dims[0]) +
                              static_cast<std::size_t>(c[0]);
    return (bits[index / kCellsPerWord] >> (index % kCellsPerWord)) & 1u;
  }
};

// The geometry of a mask over a box of edges `length` from `lo`: cubic cells of edge
// cell_target or more, at most max_cells of them (the edge grows until they fit), dims[0] rounded
// up to whole words (the grid then reaches beyond the box along x; those cells stay clear and
// are never looked up). No bits yet.
template <class Real>
PenetrationMask<Real> penetration_mask_geometry(const Real lo[3], const Real length[3],
                                                double cell_target, double max_cells) {
  PenetrationMask<Real> m;
  double edge = cell_target;
  auto cells_along = [&](int a) { return std::ceil(static_cast<double>(length[a]) / edge); };
  auto cells = [&]() {
    return std::ceil(cells_along(0) / m.kCellsPerWord) * m.kCellsPerWord * cells_along(1) *
           cells_along(2);
  };
  while (cells() > max_cells) edge *= 1.1;
  for (int a = 0; a < 3; ++a) {
    m.lo[a] = lo[a];
    m.dims[a] = static_cast<int>(cells_along(a));
    m.cell[a] = static_cast<Real>(edge);
    m.inv_cell[a] = static_cast<Real>(1.0 / edge);
  }
  m.dims[0] = (m.dims[0] + m.kCellsPerWord - 1) / m.kCellsPerWord * m.kCellsPerWord;
  return m;
}

}  // namespace mesorock::sim
