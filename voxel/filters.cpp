#include "voxel/filters.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "mesorock/errors.h"

namespace mesorock::voxel {
namespace {

// ---------------------------------------------------------------------------------------------
// Median

// Histogram bin of an 8-bit value (int8 is shifted so bins stay in 0..255).
template <class T>
inline unsigned bin_of(T v) {
  if constexpr (std::is_same_v<T, std::int8_t>) {
    return static_cast<unsigned>(static_cast<int>(v) + 128);
  } else {
    return static_cast<unsigned>(v);
  }
}
template <class T>
inline T value_of_bin(unsigned b) {
  if constexpr (std::is_same_v<T, std::int8_t>) {
    return static_cast<T>(static_cast<int>(b) - 128);
  } else {
    return static_cast<T>(b);
  }
}

// A window row clipped to the volume: the input row it reads and its half-width in x.
template <class T>
struct ActiveRow {
  const T* row;
  std::int64_t half_x;
};

// One output row with a sliding histogram along x (Huang et al. 1979): moving the window by one
// voxel adds the entering end of each window row and removes the leaving end, and the median bin
// moves by only as much as the counts below it changed.
template <class T>
void median_row_histogram(const std::vector<ActiveRow<T>>& rows, std::int64_t nx, T* out) {
  std::uint32_t hist[256] = {0};
  std::int64_t count = 0;
  unsigned median = 0;
  std::int64_t below = 0;  // voxels in bins < median
  auto add = [&](unsigned b) {
    ++hist[b];
    ++count;
    below += b < median;
  };
  auto remove = [&](unsigned b) {
    --hist[b];
    --count;
    below -= b < median;
  };
  for (const ActiveRow<T>& r : rows) {
    for (std::int64_t x = 0; x <= std::min(r.half_x, nx - 1); ++x) add(bin_of(r.row[x]));
  }
  for (std::int64_t x = 0; x < nx; ++x) {
    if (x > 0) {
      for (const ActiveRow<T>& r : rows) {
        const std::int64_t enter = x + r.half_x, leave = x - r.half_x - 1;
        if (enter < nx) add(bin_of(r.row[enter]));
        if (leave >= 0) remove(bin_of(r.row[leave]));
      }
    }
    const std::int64_t k = (count - 1) / 2;  // rank of the (lower) median
    while (below > k) below -= hist[--median];
    while (below + hist[median] <= k) below += hist[median++];
    out[x] = value_of_bin<T>(median);
  }
}

// One output row by selection (uint16, float32): gather the window, nth_element.
template <class T>
void median_row_select(const std::vector<ActiveRow<T>>& rows, std::int64_t nx, T* out,
                       std::vector<T>& window) {
  for (std::int64_t x = 0; x < nx; ++x) {
    window.clear();
    for (const ActiveRow<T>& r : rows) {
      const std::int64_t x0 = std::max<std::int64_t>(0, x - r.half_x);
      const std::int64_t x1 = std::min<std::int64_t>(nx - 1, x + r.half_x);
      if (x0 <= x1) window.insert(window.end(), r.row + x0, r.row + x1 + 1);
    }
    const auto mid = window.begin() + static_cast<std::ptrdiff_t>((window.size() - 1) / 2);
    std::nth_element(window.begin(), mid, window.end());
    out[x] = *mid;
  }
}

template <class T>
void median_in_place(Volume& volume, const std::vector<MedianRow>& window) {
  const Shape s = volume.shape();
  const auto slice = static_cast<std::size_t>(s.slice_voxels());
  int reach_z = 0;
  for (const MedianRow& r : window) reach_z = std::max(reach_z, std::abs(r.dz));
  // The output slice z needs the original slices z - reach .. z + reach. Slices below z have
  // already been overwritten, so their originals are kept in a ring of `reach` slices.
  const auto ring = static_cast<std::size_t>(std::max(reach_z, 1));
  std::vector<std::vector<T>> originals(reach_z > 0 ? ring : 0, std::vector<T>(slice));
  std::vector<T> result(slice);
  for (std::int64_t z = 0; z < s.nz; ++z) {
    auto plane = [&](std::int64_t zz) -> const T* {
      return zz < z ? originals[static_cast<std::size_t>(zz) % ring].data() : volume.slice<T>(zz);
    };
    tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.ny, 8),
                      [&](const tbb::blocked_range<std::int64_t>& range) {
                        std::vector<T> scratch;
                        std::vector<ActiveRow<T>> rows;
                        for (std::int64_t y = range.begin(); y != range.end(); ++y) {
                          rows.clear();
                          for (const MedianRow& r : window) {
                            const std::int64_t zz = z + r.dz, yy = y + r.dy;
                            if (zz < 0 || zz >= s.nz || yy < 0 || yy >= s.ny) continue;
                            rows.push_back({plane(zz) + yy * s.nx, r.half_x});
                          }
                          T* out = result.data() + y * s.nx;
                          if constexpr (sizeof(T) == 1) {
                            median_row_histogram<T>(rows, s.nx, out);
                          } else {
                            median_row_select<T>(rows, s.nx, out, scratch);
                          }
                        }
                      });
    T* current = volume.slice<T>(z);
    if (reach_z > 0) {
      std::copy(current, current + slice, originals[static_cast<std::size_t>(z) % ring].begin());
    }
    std::copy(result.begin(), result.end(), current);
  }
}

// ---------------------------------------------------------------------------------------------
// Gaussian

std::vector<float> gaussian_kernel(double sigma, double truncate) {
  const int half = static_cast<int>(truncate * sigma + 0.5);
  std::vector<double> w(static_cast<std::size_t>(2 * half + 1));
  double sum = 0;
  for (int k = -half; k <= half; ++k) {
    w[static_cast<std::size_t>(k + half)] = std::exp(-0.5 * k * k / (sigma * sigma));
    sum += w[static_cast<std::size_t>(k + half)];
  }
  std::vector<float> kernel(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) kernel[i] = static_cast<float>(w[i] / sum);
  return kernel;
}

// Mirrored index, scipy's "reflect": (d c b a | a b c d | d c b a).
inline std::int64_t reflect(std::int64_t i, std::int64_t n) {
  if (n == 1) return 0;
  const std::int64_t period = 2 * n;
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - 1 - i;
}

template <class T>
inline T store_as(float v) {
  if constexpr (std::is_same_v<T, float>) {
    return v;
  } else {
    const float lo = static_cast<float>(std::numeric_limits<T>::min());
    const float hi = static_cast<float>(std::numeric_limits<T>::max());
    const float c = std::clamp(v, lo, hi);
    // Round half away from zero by truncation: std::nearbyint is a library call on baseline
    // x86-64 (no SSE4.1) and dominated the whole filter.
    return static_cast<T>(static_cast<int>(c + (c >= 0 ? 0.5f : -0.5f)));
  }
}

// out[i] = sum_k w[k] in[i + k - half] over n lines of `width` floats stored `stride` apart:
// convolves along the line index with mirrored borders. Used for y (lines = rows of a slice) and z
// (lines = rows of a y-plane gathered across slices).
void convolve_lines(const float* in, std::int64_t n, std::int64_t width,
                    const std::vector<float>& kernel, float* out) {
  const auto half = static_cast<std::int64_t>(kernel.size() / 2);
  for (std::int64_t i = 0; i < n; ++i) {
    float* o = out + i * width;
    std::fill(o, o + width, 0.0f);
    for (std::int64_t k = -half; k <= half; ++k) {
      const float w = kernel[static_cast<std::size_t>(k + half)];
      const float* src = in + reflect(i + k, n) * width;
      for (std::int64_t x = 0; x < width; ++x) o[x] += w * src[x];
    }
  }
}

template <class T>
void gaussian_in_place(Volume& volume, const GaussianOptions& o) {
  const Shape s = volume.shape();
  const std::int64_t nx = s.nx, ny = s.ny, nz = s.nz;
  const bool do_x = o.sigma_x > 0 && nx > 1, do_y = o.sigma_y > 0 && ny > 1,
             do_z = o.sigma_z > 0 && nz > 1;
  const std::vector<float> kx =
      do_x ? gaussian_kernel(o.sigma_x, o.truncate) : std::vector<float>{};
  const std::vector<float> ky =
      do_y ? gaussian_kernel(o.sigma_y, o.truncate) : std::vector<float>{};
  const std::vector<float> kz =
      do_z ? gaussian_kernel(o.sigma_z, o.truncate) : std::vector<float>{};

  // Per-thread buffers, allocated once: fresh multi-megabyte vectors per slice cost more in page
  // faults and zeroing than the convolution itself.
  struct Scratch {
    std::vector<float> a, b, row;
    std::vector<float>& sized(std::vector<float>& v, std::int64_t n) {
      if (v.size() < static_cast<std::size_t>(n)) v.resize(static_cast<std::size_t>(n));
      return v;
    }
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  if (do_x || do_y) {
    // In-plane passes, one slice per task; each slice is read into floats once and written once.
    tbb::parallel_for(std::int64_t(0), nz, [&](std::int64_t z) {
      Scratch& buffers = scratch.local();
      std::vector<float>& plane = buffers.sized(buffers.a, nx * ny);
      std::vector<float>& scratch_plane = buffers.sized(buffers.b, nx * ny);
      T* slice = volume.slice<T>(z);
      const auto half = static_cast<std::int64_t>(kx.size() / 2);
      std::vector<float>& padded = buffers.sized(buffers.row, nx + 2 * half);
      for (std::int64_t y = 0; y < ny; ++y) {
        const T* row = slice + y * nx;
        float* dst = plane.data() + y * nx;
        if (!do_x) {
          for (std::int64_t x = 0; x < nx; ++x) dst[x] = static_cast<float>(row[x]);
          continue;
        }
        for (std::int64_t x = 0; x < nx; ++x) {
          padded[static_cast<std::size_t>(x + half)] = static_cast<float>(row[x]);
        }
        for (std::int64_t x = 1; x <= half; ++x) {  // mirrored margins
          padded[static_cast<std::size_t>(half - x)] = static_cast<float>(row[reflect(-x, nx)]);
          padded[static_cast<std::size_t>(nx - 1 + half + x)] =
              static_cast<float>(row[reflect(nx - 1 + x, nx)]);
        }
        // Loop over taps outside, voxels inside: the inner loop vectorises.
        std::fill(dst, dst + nx, 0.0f);
        for (std::size_t k = 0; k < kx.size(); ++k) {
          const float w = kx[k];
          const float* p = padded.data() + k;
          for (std::int64_t x = 0; x < nx; ++x) dst[x] += w * p[x];
        }
      }
      const float* result = plane.data();
      if (do_y) {
        convolve_lines(plane.data(), ny, nx, ky, scratch_plane.data());
        result = scratch_plane.data();
      }
      for (std::int64_t i = 0; i < nx * ny; ++i) slice[i] = store_as<T>(result[i]);
    });
  }
  if (do_z) {
    // z pass, one y index per task: gather the (nz x nx) plane across slices, convolve, scatter.
    tbb::parallel_for(std::int64_t(0), ny, [&](std::int64_t y) {
      Scratch& buffers = scratch.local();
      std::vector<float>& plane = buffers.sized(buffers.a, nz * nx);
      std::vector<float>& out = buffers.sized(buffers.b, nz * nx);
      for (std::int64_t z = 0; z < nz; ++z) {
        const T* row = volume.slice<T>(z) + y * nx;
        std::transform(row, row + nx, plane.begin() + z * nx,
                       [](T v) { return static_cast<float>(v); });
      }
      convolve_lines(plane.data(), nz, nx, kz, out.data());
      for (std::int64_t z = 0; z < nz; ++z) {
        T* row = volume.slice<T>(z) + y * nx;
        for (std::int64_t x = 0; x < nx; ++x) row[x] = store_as<T>(out[z * nx + x]);
      }
    });
  }
}

}  // namespace

MedianOptions cube_median(int radius) {
  MedianOptions o;
  o.radius_z = o.radius_y = o.radius_x = radius;
  return o;
}

std::vector<MedianRow> median_window(const MedianOptions& o) {
  for (double r : {o.radius_z, o.radius_y, o.radius_x}) {
    if (!std::isfinite(r) || r < 0 || r > 10) {
      throw ConfigError("median radius must be 0 to 10 voxels per axis");
    }
  }
  // A hair of tolerance so that radius 1.5 includes the voxel at (1, 1) of a 3x3 square, as
  // intended, whatever the rounding of 1/1.5^2 + 1/1.5^2.
  constexpr double kTolerance = 1e-9;
  const int reach_z = static_cast<int>(std::floor(o.radius_z + kTolerance));
  const int reach_y = static_cast<int>(std::floor(o.radius_y + kTolerance));
  std::vector<MedianRow> rows;
  for (int dz = -reach_z; dz <= reach_z; ++dz) {
    for (int dy = -reach_y; dy <= reach_y; ++dy) {
      double half = o.radius_x;
      if (o.shape == MedianShape::kBall) {
        const double fz = o.radius_z > 0 ? dz / o.radius_z : 0.0;
        const double fy = o.radius_y > 0 ? dy / o.radius_y : 0.0;
        const double left = 1.0 - fz * fz - fy * fy;
        if (left < -kTolerance) continue;
        half = o.radius_x * std::sqrt(std::max(0.0, left));
      }
      rows.push_back({dz, dy, static_cast<int>(std::floor(half + kTolerance))});
    }
  }
  if (rows.size() <= 1 && rows.front().half_x == 0) {
    throw ConfigError("median window holds a single voxel; give a radius of at least 1");
  }
  return rows;
}

void median_filter(Volume& volume, const MedianOptions& options) {
  const std::vector<MedianRow> window = median_window(options);
  visit_dtype(volume.dtype(), [&](auto tag) {
    using T = decltype(tag);
    median_in_place<T>(volume, window);
  });
}

GaussianOptions isotropic_gaussian(double sigma_voxels) {
  GaussianOptions o;
  o.sigma_z = o.sigma_y = o.sigma_x = sigma_voxels;
  return o;
}

GaussianOptions physical_gaussian(double sigma, const Spacing& spacing) {
  GaussianOptions o;
  o.sigma_z = sigma / spacing.dz;
  o.sigma_y = sigma / spacing.dy;
  o.sigma_x = sigma / spacing.dx;
  return o;
}

void gaussian_filter(Volume& volume, const GaussianOptions& options) {
  for (double s : {options.sigma_z, options.sigma_y, options.sigma_x}) {
    if (!std::isfinite(s) || s < 0 || s > 100) {
      throw ConfigError("Gaussian sigma must be 0 to 100 voxels");
    }
  }
  if (!(options.truncate > 0)) throw ConfigError("Gaussian truncate must be positive");
  if (volume.dtype() == DType::kBool) {
    throw ConfigError("a Gaussian filter on a bool volume makes no sense; segment it instead");
  }
  visit_dtype(volume.dtype(), [&](auto tag) {
    using T = decltype(tag);
    gaussian_in_place<T>(volume, options);
  });
}

void FieldOfView::row_span(std::int64_t y, std::int64_t nx, std::int64_t* first,
                           std::int64_t* last) const {
  const double dy = static_cast<double>(y) - cy;
  const double r2 = radius * radius - dy * dy;
  if (r2 < 0) {
    *first = 0;
    *last = -1;
    return;
  }
  const double half = std::sqrt(r2);
  *first = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cx - half)));
  *last = std::min<std::int64_t>(nx - 1, static_cast<std::int64_t>(std::floor(cx + half)));
}

FieldOfView inscribed_field_of_view(const Shape& shape) {
  FieldOfView fov;
  fov.cx = (static_cast<double>(shape.nx) - 1) / 2;
  fov.cy = (static_cast<double>(shape.ny) - 1) / 2;
  fov.radius = static_cast<double>(std::min(shape.nx, shape.ny)) / 2;
  return fov;
}

FieldOfView field_of_view_from_value(const Volume& volume, double outside_value) {
  const Shape s = volume.shape();
  struct Sums {
    double count = 0, x = 0, y = 0;
  };
  std::vector<Sums> per_slice(static_cast<std::size_t>(s.nz));
  visit_dtype(volume.dtype(), [&](auto tag) {
    using T = decltype(tag);
    tbb::parallel_for(std::int64_t(0), s.nz, [&](std::int64_t z) {
      const T* slice = volume.slice<T>(z);
      Sums sums;
      for (std::int64_t y = 0; y < s.ny; ++y) {
        std::int64_t row_count = 0, row_x = 0;
        for (std::int64_t x = 0; x < s.nx; ++x) {
          if (static_cast<double>(slice[y * s.nx + x]) != outside_value) {
            ++row_count;
            row_x += x;
          }
        }
        sums.count += static_cast<double>(row_count);
        sums.x += static_cast<double>(row_x);
        sums.y += static_cast<double>(row_count) * static_cast<double>(y);
      }
      per_slice[static_cast<std::size_t>(z)] = sums;
    });
  });
  Sums total;
  for (const Sums& p : per_slice) {
    total.count += p.count;
    total.x += p.x;
    total.y += p.y;
  }
  if (total.count == 0) {
    throw ConfigError("every voxel equals the outside value " + std::to_string(outside_value) +
                      "; no field of view to find");
  }
  FieldOfView fov;
  fov.cx = total.x / total.count;
  fov.cy = total.y / total.count;
  fov.radius = std::sqrt(total.count / static_cast<double>(s.nz) / M_PI);
  return fov;
}

std::int64_t apply_field_of_view(Volume& volume, const FieldOfView& fov, double fill) {
  const Shape s = volume.shape();
  std::vector<std::int64_t> outside(static_cast<std::size_t>(s.nz), 0);
  visit_dtype(volume.dtype(), [&](auto tag) {
    using T = decltype(tag);
    const double lo =
        volume.dtype() == DType::kBool ? 0.0 : double(std::numeric_limits<T>::lowest());
    const double hi = volume.dtype() == DType::kBool ? 1.0 : double(std::numeric_limits<T>::max());
    if (!(fill >= lo && fill <= hi) || (is_integer(volume.dtype()) && fill != std::floor(fill))) {
      throw ConfigError("fill value " + std::to_string(fill) + " does not fit a " +
                        dtype_name(volume.dtype()) + " volume");
    }
    const T value = static_cast<T>(fill);
    tbb::parallel_for(std::int64_t(0), s.nz, [&](std::int64_t z) {
      T* slice = volume.slice<T>(z);
      std::int64_t n = 0;
      for (std::int64_t y = 0; y < s.ny; ++y) {
        std::int64_t first, last;
        fov.row_span(y, s.nx, &first, &last);
        T* row = slice + y * s.nx;
        if (last < first) {
          std::fill(row, row + s.nx, value);
          n += s.nx;
          continue;
        }
        std::fill(row, row + first, value);
        std::fill(row + last + 1, row + s.nx, value);
        n += first + (s.nx - 1 - last);
      }
      outside[static_cast<std::size_t>(z)] = n;
    });
  });
  std::int64_t total = 0;
  for (std::int64_t n : outside) total += n;
  return total;
}

}  // namespace mesorock::voxel
