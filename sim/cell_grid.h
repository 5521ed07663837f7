#pragma once
// Uniform cell grid over the box with cells at least rc = 1 wide. Backends sort the particle
// storage by cell (cell_start offsets); this header only holds the geometry and the
// neighbour-cell enumeration shared by every kernel.
#include <cmath>

#include "sim/box.h"
#include "sim/hd.h"

namespace mesorock::sim {

template <class Real>
struct CellGrid {
  int dims[3] = {1, 1, 1};
  Real inv_cell[3] = {1, 1, 1};

  static CellGrid make(const Box<Real>& box, Real cutoff) {
    CellGrid g;
    for (int a = 0; a < 3; ++a) {
      const int n = static_cast<int>(std::floor(static_cast<double>(box.length[a]) / cutoff));
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

  // The distinct neighbour coordinates of cell c along one axis (itself included), and the image
  // shift to add to a neighbour's coordinate so that x_i - (x_j + shift) is the minimum image.
  // Returns the count. With fewer than 3 cells on a periodic axis, c-1 and c+1 are the same cell
  // (n = 2) or c itself (n = 1): each is listed once, which keeps every pair from being counted
  // twice, and `needs_minimum_image` is set because one cell then holds neighbours of both images.
  MESO_HD MESO_INLINE int axis_neighbours(int c, int axis, bool periodic, Real length, int out[3],
                                          Real shift[3], bool& needs_minimum_image) const {
    const int n = dims[axis];
    needs_minimum_image = false;
    shift[0] = shift[1] = shift[2] = Real(0);
    if (periodic) {
      if (n < 3) {
        needs_minimum_image = true;
        out[0] = 0;
        out[1] = 1;
        return n;
      }
      out[0] = c == 0 ? n - 1 : c - 1;
      if (c == 0) shift[0] = -length;
      out[1] = c;
      out[2] = c == n - 1 ? 0 : c + 1;
      if (c == n - 1) shift[2] = length;
      return 3;
    }
    int k = 0;
    if (c > 0) out[k++] = c - 1;
    out[k++] = c;
    if (c < n - 1) out[k++] = c + 1;
    return k;
  }
};

}  // namespace mesorock::sim
