#pragma once
// Brute-force reference implementations for the pore-analysis tests, written independently of
// voxel/: flood fill for clusters, nearest non-pore voxel by exhaustive search for distances,
// every sphere against every voxel for local thickness, and a box search for wall voxels. Slow
// on purpose; for volumes of a few thousand voxels.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <random>
#include <vector>

#include "voxel/volume.h"

namespace mesorock::voxel::test {

inline bool ref_pore(std::uint8_t c) {
  return c == 1 || c == 4;
}
inline bool ref_solid(std::uint8_t c) {
  return c == 2 || c == 3;
}

// Labels drawn at random: each voxel pore with probability `pore`, else outside with
// probability `outside`, else organic or inorganic; pore voxels are pore or organic_pore.
inline Volume random_labels(const Shape& shape, double pore, double outside, std::uint64_t seed,
                            Spacing spacing = {}) {
  Volume v(shape, DType::kUInt8, spacing);
  std::mt19937_64 rng(seed);
  auto u = [&] { return double(rng() >> 11) * 0x1.0p-53; };
  std::uint8_t* p = v.data<std::uint8_t>();
  for (std::int64_t i = 0; i < v.voxels(); ++i) {
    const double r = u();
    if (r < pore) {
      p[i] = u() < 0.5 ? 1 : 4;
    } else if (r < pore + outside) {
      p[i] = 0;
    } else {
      p[i] = u() < 0.5 ? 2 : 3;
    }
  }
  return v;
}

// Solid (inorganic, some organic) with random pore balls of radius [rmin, rmax) voxels, so
// that pores have sizes worth measuring.
inline Volume random_balls(const Shape& shape, int balls, double rmin, double rmax,
                           std::uint64_t seed, Spacing spacing = {}) {
  Volume v(shape, DType::kUInt8, spacing);
  std::mt19937_64 rng(seed);
  auto u = [&] { return double(rng() >> 11) * 0x1.0p-53; };
  std::uint8_t* p = v.data<std::uint8_t>();
  for (std::int64_t i = 0; i < v.voxels(); ++i) p[i] = u() < 0.2 ? 2 : 3;
  for (int b = 0; b < balls; ++b) {
    const double cz = u() * double(shape.nz), cy = u() * double(shape.ny),
                 cx = u() * double(shape.nx), r = rmin + (rmax - rmin) * u();
    for (std::int64_t z = 0; z < shape.nz; ++z)
      for (std::int64_t y = 0; y < shape.ny; ++y)
        for (std::int64_t x = 0; x < shape.nx; ++x) {
          const double d2 = (double(z) - cz) * (double(z) - cz) +
                            (double(y) - cy) * (double(y) - cy) +
                            (double(x) - cx) * (double(x) - cx);
          if (d2 < r * r) p[(z * shape.ny + y) * shape.nx + x] = 1;
        }
  }
  return v;
}

struct RefCluster {
  std::int64_t voxels = 0;
  unsigned faces = 0;
  std::array<std::int64_t, 3> lo{}, hi{};
};

// Flood fill from seeds in C order: clusters come out in the order of their first voxel.
inline std::vector<RefCluster> ref_clusters(const Volume& labels, int connectivity) {
  const Shape s = labels.shape();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  std::vector<char> seen(static_cast<std::size_t>(s.voxels()), 0);
  std::vector<RefCluster> out;
  std::deque<std::array<std::int64_t, 3>> queue;
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::int64_t i = (z * s.ny + y) * s.nx + x;
        if (!ref_pore(p[i]) || seen[std::size_t(i)]) continue;
        RefCluster c;
        c.lo = {z, y, x};
        c.hi = {z, y, x};
        seen[std::size_t(i)] = 1;
        queue.push_back({z, y, x});
        while (!queue.empty()) {
          const auto v = queue.front();
          queue.pop_front();
          ++c.voxels;
          const std::int64_t n[3] = {s.nz, s.ny, s.nx};
          for (int a = 0; a < 3; ++a) {
            c.lo[a] = std::min(c.lo[a], v[a]);
            c.hi[a] = std::max(c.hi[a], v[a]);
            if (v[a] == 0) c.faces |= 1u << (2 * a);
            if (v[a] == n[a] - 1) c.faces |= 1u << (2 * a + 1);
          }
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int nonzero = (dz != 0) + (dy != 0) + (dx != 0);
                if (nonzero == 0 || (connectivity == 6 && nonzero > 1)) continue;
                const std::int64_t w[3] = {v[0] + dz, v[1] + dy, v[2] + dx};
                if (w[0] < 0 || w[1] < 0 || w[2] < 0 || w[0] >= s.nz || w[1] >= s.ny ||
                    w[2] >= s.nx)
                  continue;
                const std::int64_t j = (w[0] * s.ny + w[1]) * s.nx + w[2];
                if (!ref_pore(p[j]) || seen[std::size_t(j)]) continue;
                seen[std::size_t(j)] = 1;
                queue.push_back({w[0], w[1], w[2]});
              }
        }
        out.push_back(c);
      }
  return out;
}

// Squared distance (double) from each voxel to the nearest voxel that is not pore; 0 for voxels
// that are not pore, infinity when there is none.
inline std::vector<double> ref_squared_distance(const Volume& labels) {
  const Shape s = labels.shape();
  const Spacing& h = labels.spacing();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  std::vector<std::array<std::int64_t, 3>> walls;
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x)
        if (!ref_pore(p[(z * s.ny + y) * s.nx + x])) walls.push_back({z, y, x});
  std::vector<double> d(static_cast<std::size_t>(s.voxels()), 0.0);
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::int64_t i = (z * s.ny + y) * s.nx + x;
        if (!ref_pore(p[i])) continue;
        double best = std::numeric_limits<double>::infinity();
        for (const auto& w : walls) {
          const double tz = double(z - w[0]) * h.dz, ty = double(y - w[1]) * h.dy,
                       tx = double(x - w[2]) * h.dx;
          best = std::min(best, tz * tz + ty * ty + tx * tx);
        }
        d[std::size_t(i)] = best;
      }
  return d;
}

// Local thickness by definition: for each pore voxel q, 2 max R_c over all pore centres c with
// |q - c|^2 < R_c^2.
inline std::vector<double> ref_local_thickness(const Volume& labels) {
  const Shape s = labels.shape();
  const Spacing& h = labels.spacing();
  const std::vector<double> d2 = ref_squared_distance(labels);
  struct C {
    std::int64_t z, y, x;
    double r2;
  };
  std::vector<C> centres;
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const double r2 = d2[std::size_t((z * s.ny + y) * s.nx + x)];
        if (r2 > 0) centres.push_back({z, y, x, r2});
      }
  std::vector<double> t(d2.size(), 0.0);
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::size_t i = std::size_t((z * s.ny + y) * s.nx + x);
        if (d2[i] == 0) continue;
        double best = 0;
        for (const C& c : centres) {
          const double tz = double(z - c.z) * h.dz, ty = double(y - c.y) * h.dy,
                       tx = double(x - c.x) * h.dx;
          if (tz * tz + ty * ty + tx * tx < c.r2) best = std::max(best, c.r2);
        }
        t[i] = 2 * std::sqrt(best);
      }
  return t;
}

// 1 for solid voxels with a pore voxel within |dz| <= lz, |dy| <= ly, |dx| <= lx.
inline std::vector<char> ref_walls(const Volume& labels, const std::array<int, 3>& layers) {
  const Shape s = labels.shape();
  const std::uint8_t* p = labels.data<std::uint8_t>();
  std::vector<char> wall(static_cast<std::size_t>(s.voxels()), 0);
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::int64_t i = (z * s.ny + y) * s.nx + x;
        if (!ref_solid(p[i])) continue;
        bool near = false;
        for (std::int64_t a = std::max<std::int64_t>(0, z - layers[0]);
             a <= std::min(s.nz - 1, z + layers[0]) && !near; ++a)
          for (std::int64_t b = std::max<std::int64_t>(0, y - layers[1]);
               b <= std::min(s.ny - 1, y + layers[1]) && !near; ++b)
            for (std::int64_t c = std::max<std::int64_t>(0, x - layers[2]);
                 c <= std::min(s.nx - 1, x + layers[2]); ++c)
              if (ref_pore(p[(a * s.ny + b) * s.nx + c])) {
                near = true;
                break;
              }
        wall[std::size_t(i)] = near;
      }
  return wall;
}

}  // namespace mesorock::voxel::test
