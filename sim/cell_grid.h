#pragma once
// Uniform cell grid over the box with cells at least rc / reach wide, so that every neighbour
// within rc of a particle lies within `reach` cells of its own along each axis. Backends sort the
// particle storage by cell (cell_start offsets); this header only holds the geometry and the
// stencil shared by every kernel.
//
// The scan covers (2 reach + 1)^3 cells of volume (1 / reach)^3: 27 rc^3 of candidates with
// reach 1, 15.6 rc^3 with reach 2, for the same 4.2 rc^3 sphere of neighbours. Fewer candidates
// did not pay on the GPU, where more and shorter rows cost more than the candidates they save
// (H200, porous 16 M: 756 MPS/s with reach 1, 655 with 2, 526 with 3; docs/benchmarks.md).
#include <cmath>

#include "sim/box.h"
#include "sim/hd.h"

namespace mesorock::sim {

template <class Real>
struct CellGrid {
  int dims[3] = {1, 1, 1};
  Real inv_cell[3] = {1, 1, 1};
  int reach = 1;  // cells per cutoff

  static CellGrid make(const Box<Real>& box, Real cutoff, int cells_per_cutoff = 1) {
    CellGrid g;
    g.reach = cells_per_cutoff < 1 ? 1 : cells_per_cutoff;
    const double width = static_cast<double>(cutoff) / g.reach;
    for (int a = 0; a < 3; ++a) {
      const int n = static_cast<int>(std::floor(static_cast<double>(box.length[a]) / width));
      g.dims[a] = n < 1 ? 1 : n;
      g.inv_cell[a] = static_cast<Real>(g.dims[a] / static_cast<double>(box.length[a]));
    }
    return g;
  }

  MESO_HD int count() const { return dims[0] * dims[1] * dims[2]; }

  MESO_HD MESO_INLINE int coordinate(Real x, Real lo, int axis) const {
    int c = static_cast<int>((x - lo) * inv_cell[axis]);
    c = c < 0 ? 0 : c;
    return c >= dims[axis] ? dims[axis] - 1 : c;
  }

  MESO_HD MESO_INLINE int index(int cx, int cy, int cz) const {
    return (cz * dims[1] + cy) * dims[0] + cx;
  }

  // The stencil along one axis around cell c: stencil coordinates k in [begin, end), mapped to
  // cells by `wrap`. On a periodic axis with fewer than 2 reach + 1 cells the stencil would list
  // some cell twice (with reach 1 and 2 cells, c-1 and c+1 coincide): it then lists each of the
  // axis's cells once and sets `all`, and the caller takes the minimum image per pair instead of
  // a per-cell shift, so no pair is counted twice.
  struct AxisRange {
    int begin = 0, end = 0;
    bool all = false;
  };
  MESO_HD MESO_INLINE AxisRange axis_range(int c, int axis, bool periodic) const {
    const int n = dims[axis];
    AxisRange r;
    if (periodic) {
      if (n < 2 * reach + 1) {
        r.begin = 0;
        r.end = n;
        r.all = true;
      } else {
        r.begin = c - reach;
        r.end = c + reach + 1;
      }
      return r;
    }
    r.begin = c - reach < 0 ? 0 : c - reach;
    r.end = c + reach + 1 > n ? n : c + reach + 1;
    return r;
  }

  // The cell of stencil coordinate k along an axis, and the image shift to add to the positions
  // in it so that x_i - (x_j + shift) is the minimum image (k < 0 or k >= n only on a periodic
  // axis with at least 2 reach + 1 cells).
  MESO_HD MESO_INLINE int wrap(int k, int axis, Real length, Real& shift) const {
    const int n = dims[axis];
    shift = Real(0);
    if (k < 0) {
      shift = -length;
      return k + n;
    }
    if (k >= n) {
      shift = length;
      return k - n;
    }
    return k;
  }
};

}  // namespace mesorock::sim
