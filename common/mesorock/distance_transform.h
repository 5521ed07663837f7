#pragma once
// The one-dimensional pass of the exact Euclidean distance transform (Felzenszwalb and
// Huttenlocher 2012, "Distance transforms of sampled functions"): the lower envelope of parabolas.
// A 3-D squared distance is three such passes, one per axis. Shared by the voxel tools (rockprep's
// pore sizes) and rockflow (the drainage placement of `rockflow relperm`), which link no common
// voxel library.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace mesorock {

// Scratch of one line transform, reused across lines.
struct DistanceLineScratch {
  std::vector<double> f;
  std::vector<std::int64_t> v;  // parabola apexes of the lower envelope
  std::vector<double> z;        // boundaries between them
  void reserve(std::int64_t n) {
    f.resize(static_cast<std::size_t>(n));
    v.resize(static_cast<std::size_t>(n));
    z.resize(static_cast<std::size_t>(n + 1));
  }
};

// In place along one line of n values at `stride`: d(q) = min_p ((q - p) h)^2 + f(p), the lower
// envelope of parabolas rooted at the finite values, with sample spacing h. All-infinite lines
// stay infinite. `s` must have been reserved for at least n.
inline void squared_distance_line(float* line, std::int64_t n, std::int64_t stride, double h,
                                  DistanceLineScratch& s) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (std::int64_t q = 0; q < n; ++q) s.f[static_cast<std::size_t>(q)] = double(line[q * stride]);
  std::int64_t k = -1;
  for (std::int64_t q = 0; q < n; ++q) {
    const double fq = s.f[static_cast<std::size_t>(q)];
    if (std::isinf(fq)) continue;
    const double pq = double(q) * h;
    double boundary = -kInf;
    while (k >= 0) {
      const std::int64_t p = s.v[static_cast<std::size_t>(k)];
      const double pp = double(p) * h;
      boundary = ((fq + pq * pq) - (s.f[static_cast<std::size_t>(p)] + pp * pp)) / (2 * (pq - pp));
      if (boundary <= s.z[static_cast<std::size_t>(k)]) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    s.v[static_cast<std::size_t>(k)] = q;
    s.z[static_cast<std::size_t>(k)] = k == 0 ? -kInf : boundary;
    s.z[static_cast<std::size_t>(k + 1)] = kInf;
  }
  if (k < 0) return;
  std::int64_t j = 0;
  for (std::int64_t q = 0; q < n; ++q) {
    const double pq = double(q) * h;
    while (s.z[static_cast<std::size_t>(j + 1)] < pq) ++j;
    const std::int64_t p = s.v[static_cast<std::size_t>(j)];
    const double d = pq - double(p) * h;
    line[q * stride] = static_cast<float>(d * d + s.f[static_cast<std::size_t>(p)]);
  }
}

}  // namespace mesorock
