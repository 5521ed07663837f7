#pragma once
// Simulation box: an axis-aligned cuboid, each axis periodic or bounded by reflective faces.
#include "sim/hd.h"

namespace mesorock::sim {

template <class Real>
struct Box {
  Real lo[3] = {0, 0, 0};
  Real length[3] = {1, 1, 1};
  bool periodic[3] = {true, true, true};
  // A face across which particles leave freely: a rank's face inside a decomposed box
  // (sim/domain). Only on non-periodic axes; reflective otherwise.
  bool open_lo[3] = {false, false, false};
  bool open_hi[3] = {false, false, false};

  MESO_HD Real hi(int axis) const { return lo[axis] + length[axis]; }
  MESO_HD Real volume() const { return length[0] * length[1] * length[2]; }

  // Minimum-image separation along one axis. Positions are kept inside the box, so |d| < L and
  // one conditional shift suffices; d and -d map to exact negatives, keeping F_ij = -F_ji.
  MESO_HD MESO_INLINE Real minimum_image(Real d, int axis) const {
    if (!periodic[axis]) return d;
    const Real half = Real(0.5) * length[axis];
    if (d > half) return d - length[axis];
    if (d < -half) return d + length[axis];
    return d;
  }
};

}  // namespace mesorock::sim
