#include "voxel/local_thickness.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "mesorock/distance_transform.h"
#include "mesorock/errors.h"
#include "voxel/pore_analysis.h"
#include "voxel/segment.h"

namespace mesorock::voxel {
namespace {

struct Centre {
  std::int32_t z, y, x;
  float r2;
};

}  // namespace

Volume squared_pore_distance(const Volume& labels) {
  if (labels.dtype() != DType::kUInt8) {
    throw ConfigError("distance transform needs a uint8 phase-label volume");
  }
  const Shape s = labels.shape();
  const Spacing& sp = labels.spacing();
  const std::uint8_t* codes = labels.data<std::uint8_t>();
  Volume dist(s, DType::kFloat32, sp);
  float* d = dist.data<float>();
  const float inf = std::numeric_limits<float>::infinity();
  // x: distance to the nearest voxel that is not pore in the same row, two sweeps.
  tbb::parallel_for(
      tbb::blocked_range<std::int64_t>(0, s.nz * s.ny, 64),
      [&](const tbb::blocked_range<std::int64_t>& range) {
        for (std::int64_t r = range.begin(); r < range.end(); ++r) {
          const std::uint8_t* c = codes + r * s.nx;
          float* out = d + r * s.nx;
          std::int64_t last = -1;
          for (std::int64_t x = 0; x < s.nx; ++x) {
            if (!is_pore_code(c[x])) last = x;
            out[x] =
                last < 0 ? inf : float((double(x - last) * sp.dx) * (double(x - last) * sp.dx));
          }
          last = -1;
          for (std::int64_t x = s.nx - 1; x >= 0; --x) {
            if (!is_pore_code(c[x])) last = x;
            if (last < 0) continue;
            const double t = double(last - x) * sp.dx;
            out[x] = std::min(out[x], float(t * t));
          }
        }
      });
  // y: per z slice, the columns.
  tbb::parallel_for(std::int64_t(0), s.nz, [&](std::int64_t z) {
    DistanceLineScratch scratch;
    scratch.reserve(s.ny);
    float* slice = d + z * s.ny * s.nx;
    for (std::int64_t x = 0; x < s.nx; ++x)
      squared_distance_line(slice + x, s.ny, s.nx, sp.dy, scratch);
  });
  // z: per y, the (z, x) plane copied into a compact buffer so that the lines along z read
  // neighbouring memory.
  tbb::parallel_for(std::int64_t(0), s.ny, [&](std::int64_t y) {
    DistanceLineScratch scratch;
    scratch.reserve(s.nz);
    std::vector<float> plane(static_cast<std::size_t>(s.nz * s.nx));
    for (std::int64_t z = 0; z < s.nz; ++z) {
      std::copy_n(d + (z * s.ny + y) * s.nx, s.nx, plane.data() + z * s.nx);
    }
    for (std::int64_t x = 0; x < s.nx; ++x) {
      squared_distance_line(plane.data() + x, s.nz, s.nx, sp.dz, scratch);
    }
    for (std::int64_t z = 0; z < s.nz; ++z) {
      std::copy_n(plane.data() + z * s.nx, s.nx, d + (z * s.ny + y) * s.nx);
    }
  });
  return dist;
}

Volume local_thickness(const Volume& labels, const LocalThicknessOptions& options) {
  Volume out = squared_pore_distance(labels);
  const Shape s = labels.shape();
  const Spacing& sp = labels.spacing();
  const std::uint8_t* codes = labels.data<std::uint8_t>();
  float* d = out.data<float>();
  const double h[3] = {sp.dz, sp.dy, sp.dx};

  // 1. Sphere centres (per z slice, concatenated in z order).
  std::vector<std::vector<Centre>> per_slice(static_cast<std::size_t>(s.nz));
  std::vector<char> unbounded(static_cast<std::size_t>(s.nz), 0);
  tbb::parallel_for(std::int64_t(0), s.nz, [&](std::int64_t z) {
    std::vector<Centre>& list = per_slice[static_cast<std::size_t>(z)];
    for (std::int64_t y = 0; y < s.ny; ++y) {
      for (std::int64_t x = 0; x < s.nx; ++x) {
        const std::int64_t i = (z * s.ny + y) * s.nx + x;
        if (!is_pore_code(codes[i])) continue;
        const float r2 = d[i];
        if (std::isinf(r2)) {
          unbounded[static_cast<std::size_t>(z)] = 1;
          return;
        }
        bool contained = false;
        if (options.skip_contained_spheres) {
          // Sphere (c, R) lies inside sphere (n, Rn) when Rn >= R + L, L = |n - c|; tested on the
          // squares, Rn^2 - R^2 - L^2 >= 2 R L, in long double so that dyadic spacings and
          // voxel offsets give the exact answer.
          const long double R2 = r2;
          for (int dz = -1; dz <= 1 && !contained; ++dz) {
            if (z + dz < 0 || z + dz >= s.nz) continue;
            for (int dy = -1; dy <= 1 && !contained; ++dy) {
              if (y + dy < 0 || y + dy >= s.ny) continue;
              for (int dx = -1; dx <= 1; ++dx) {
                if ((dz | dy | dx) == 0 || x + dx < 0 || x + dx >= s.nx) continue;
                const std::int64_t j = i + (dz * s.ny + dy) * s.nx + dx;
                if (!is_pore_code(codes[j]) || std::isinf(d[j])) continue;
                const long double Rn2 = d[j];
                if (Rn2 <= R2) continue;
                const long double L2 = (long double)(dz * h[0]) * (dz * h[0]) +
                                       (long double)(dy * h[1]) * (dy * h[1]) +
                                       (long double)(dx * h[2]) * (dx * h[2]);
                const long double lhs = Rn2 - R2 - L2;
                if (lhs >= 0 && lhs * lhs >= 4 * R2 * L2) {
                  contained = true;
                  break;
                }
              }
            }
          }
        }
        if (!contained) {
          list.push_back({static_cast<std::int32_t>(z), static_cast<std::int32_t>(y),
                          static_cast<std::int32_t>(x), r2});
        }
      }
    }
  });
  if (std::any_of(unbounded.begin(), unbounded.end(), [](char c) { return c != 0; })) {
    throw ConfigError("local thickness is undefined: every voxel is pore, so no sphere is bounded");
  }
  std::vector<Centre> centres;
  {
    std::size_t total = 0;
    for (const auto& l : per_slice) total += l.size();
    centres.reserve(total);
    for (auto& l : per_slice) {
      centres.insert(centres.end(), l.begin(), l.end());
      std::vector<Centre>().swap(l);
    }
  }
  float max_r2 = 0;
  for (const Centre& c : centres) max_r2 = std::max(max_r2, c.r2);
  const std::int64_t reach_z = static_cast<std::int64_t>(std::floor(std::sqrt(max_r2) / h[0]));

  // 2. Paint: the buffer now holds the largest R^2 of the spheres covering each voxel.
  std::fill_n(d, s.voxels(), 0.0f);
  constexpr std::int64_t kChunk = 2;
  tbb::parallel_for(std::int64_t(0), (s.nz + kChunk - 1) / kChunk, [&](std::int64_t chunk) {
    const std::int64_t z0 = chunk * kChunk, z1 = std::min(s.nz, z0 + kChunk);
    auto first =
        std::lower_bound(centres.begin(), centres.end(), z0 - reach_z,
                         [](const Centre& c, std::int64_t z) { return std::int64_t(c.z) < z; });
    for (auto it = first; it != centres.end() && it->z < z1 + reach_z; ++it) {
      const Centre& c = *it;
      const double R2 = c.r2;
      const double R = std::sqrt(R2);
      const std::int64_t rz = static_cast<std::int64_t>(std::floor(R / h[0]));
      const std::int64_t za = std::max(z0, std::int64_t(c.z) - rz);
      const std::int64_t zb = std::min(z1 - 1, std::int64_t(c.z) + rz);
      for (std::int64_t z = za; z <= zb; ++z) {
        const double tz = double(z - c.z) * h[0];
        const double rem_z = R2 - tz * tz;
        if (rem_z <= 0) continue;
        const std::int64_t ry = static_cast<std::int64_t>(std::floor(std::sqrt(rem_z) / h[1]));
        const std::int64_t ya = std::max<std::int64_t>(0, c.y - ry);
        const std::int64_t yb = std::min<std::int64_t>(s.ny - 1, c.y + ry);
        for (std::int64_t y = ya; y <= yb; ++y) {
          const double ty = double(y - c.y) * h[1];
          const double rem_y = R2 - (tz * tz + ty * ty);
          if (rem_y <= 0) continue;
          const std::int64_t rx = static_cast<std::int64_t>(std::floor(std::sqrt(rem_y) / h[2]));
          const std::int64_t xa = std::max<std::int64_t>(0, c.x - rx);
          const std::int64_t xb = std::min<std::int64_t>(s.nx - 1, c.x + rx);
          float* row = d + (z * s.ny + y) * s.nx;
          for (std::int64_t x = xa; x <= xb; ++x) {
            const double tx = double(x - c.x) * h[2];
            if (tz * tz + ty * ty + tx * tx < R2 && row[x] < c.r2) row[x] = c.r2;
          }
        }
      }
    }
  });
  // 3. Diameters.
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.voxels(), 1 << 16),
                    [&](const tbb::blocked_range<std::int64_t>& range) {
                      for (std::int64_t i = range.begin(); i < range.end(); ++i) {
                        d[i] = d[i] > 0 ? float(2.0 * std::sqrt(double(d[i]))) : 0.0f;
                      }
                    });
  return out;
}

SizeDistribution size_distribution(const Volume& thickness, const Volume& labels, int bins) {
  if (thickness.dtype() != DType::kFloat32 || thickness.shape() != labels.shape() ||
      labels.dtype() != DType::kUInt8) {
    throw ConfigError("size distribution: thickness and labels volumes do not match");
  }
  if (bins < 0) throw ConfigError("size distribution: bins must be positive");
  const float* t = thickness.data<float>();
  const std::uint8_t* codes = labels.data<std::uint8_t>();
  const std::int64_t n = labels.voxels();
  SizeDistribution dist;
  double sum = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    if (!is_pore_code(codes[i])) continue;
    ++dist.pore_voxels;
    dist.max = std::max(dist.max, double(t[i]));
    sum += t[i];
  }
  if (dist.pore_voxels == 0) return dist;
  dist.mean = sum / double(dist.pore_voxels);
  const Spacing& sp = labels.spacing();
  double width = std::min({sp.dz, sp.dy, sp.dx});
  int count = bins;
  if (count > 0) {
    width = dist.max / count;
  } else {
    // The largest value opens the last bin, [k w, (k + 1) w).
    count = static_cast<int>(std::floor(dist.max / width)) + 1;
    if (count > 100) {
      count = 100;
      width = dist.max / count;
    }
  }
  if (!(width > 0)) width = 1;
  dist.edges.resize(static_cast<std::size_t>(count) + 1);
  for (int i = 0; i <= count; ++i) dist.edges[static_cast<std::size_t>(i)] = width * i;
  dist.voxels.assign(static_cast<std::size_t>(count), 0);
  for (std::int64_t i = 0; i < n; ++i) {
    if (!is_pore_code(codes[i])) continue;
    const int b = std::min(count - 1, static_cast<int>(double(t[i]) / width));
    ++dist.voxels[static_cast<std::size_t>(std::max(0, b))];
  }
  dist.volume_fraction.resize(dist.voxels.size());
  double below = 0;
  bool median_found = false;
  for (std::size_t b = 0; b < dist.voxels.size(); ++b) {
    const double f = double(dist.voxels[b]) / double(dist.pore_voxels);
    dist.volume_fraction[b] = f;
    if (!median_found && below + f >= 0.5 && f > 0) {
      dist.median = dist.edges[b] + (0.5 - below) / f * width;
      median_found = true;
    }
    below += f;
  }
  return dist;
}

double critical_pore_diameter(const Volume& labels, int axis_zyx) {
  if (axis_zyx < 0 || axis_zyx > 2)
    throw ConfigError("critical pore diameter: axis must be 0 to 2");
  const Volume sq = squared_pore_distance(labels);
  const float* d2 = sq.data<float>();
  const std::uint8_t* codes = labels.data<std::uint8_t>();
  const std::size_t n = static_cast<std::size_t>(labels.voxels());
  // The candidate diameters: the distinct 2 x distance values of the pore voxels.
  std::vector<float> values;
  for (std::size_t i = 0; i < n; ++i)
    if (is_pore_code(codes[i]) && std::isfinite(d2[i])) values.push_back(d2[i]);
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  Volume open(labels.shape(), DType::kUInt8, labels.spacing());
  std::uint8_t* o = open.data<std::uint8_t>();
  auto passes = [&](float min_d2) {
    for (std::size_t i = 0; i < n; ++i)
      o[i] = static_cast<std::uint8_t>(
          is_pore_code(codes[i]) && d2[i] >= min_d2 ? Phase::kPore : Phase::kInorganic);
    for (const Cluster& c : find_pore_clusters(find_pore_runs(open)))
      if (c.spans(axis_zyx)) return true;
    return false;
  };
  if (values.empty() || !passes(values.front())) return 0.0;
  // passes() is monotone in the threshold: the largest value that still passes.
  std::size_t lo = 0, hi = values.size();  // values[lo] passes; values[hi] (if any) does not
  while (hi - lo > 1) {
    const std::size_t mid = lo + (hi - lo) / 2;
    (passes(values[mid]) ? lo : hi) = mid;
  }
  return 2.0 * std::sqrt(static_cast<double>(values[lo]));
}

}  // namespace mesorock::voxel
