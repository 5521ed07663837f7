#pragma once
// Solid masks for the lattice Boltzmann tests.
#include <cstdint>
#include <functional>

#include "sim/solid_grid.h"

namespace mesorock::test {

// A mask of nx x ny x nz voxels, solid where solid(i, j, k) holds.
inline sim::SolidMask make_mask(
    std::int64_t nx, std::int64_t ny, std::int64_t nz,
    const std::function<bool(std::int64_t, std::int64_t, std::int64_t)>& solid) {
  sim::SolidMask m;
  m.dims = {nx, ny, nz};
  m.solid.assign(static_cast<std::size_t>(nx * ny * nz), 0);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) m.solid[m.index(i, j, k)] = solid(i, j, k) ? 1 : 0;
  return m;
}

}  // namespace mesorock::test
