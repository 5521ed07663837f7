#include "voxel/roi.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <type_traits>
#include <vector>

#include "mesorock/errors.h"
#include "voxel/io_common.h"

namespace mesorock::voxel {
namespace {

constexpr const char* kAxes[3] = {"z", "y", "x"};

// "A:B,C:D,E:F" -> three pairs of numbers.
std::array<std::array<double, 2>, 3> parse_ranges(const std::string& text,
                                                  const std::string& option) {
  const std::vector<std::string> parts = split(text, ',');
  if (parts.size() != 3) {
    throw ConfigError(option + ": expected Z0:Z1,Y0:Y1,X0:X1, got '" + text + "'");
  }
  std::array<std::array<double, 2>, 3> out{};
  for (std::size_t a = 0; a < 3; ++a) {
    const std::vector<std::string> ends = split(parts[a], ':');
    if (ends.size() != 2) {
      throw ConfigError(option + ": expected Z0:Z1,Y0:Y1,X0:X1, got '" + text + "'");
    }
    for (std::size_t e = 0; e < 2; ++e) {
      const std::string t = trim(ends[e]);
      char* end = nullptr;
      const double v = std::strtod(t.c_str(), &end);
      if (t.empty() || *end != '\0' || !std::isfinite(v)) {
        throw ConfigError(option + ": '" + t + "' in '" + text + "' is not a number");
      }
      out[a][e] = v;
    }
  }
  return out;
}

double spacing_of(const Spacing& s, int axis) {
  return axis == 0 ? s.dz : axis == 1 ? s.dy : s.dx;
}
std::int64_t extent_of(const Shape& s, int axis) {
  return axis == 0 ? s.nz : axis == 1 ? s.ny : s.nx;
}

template <class T>
T round_to(double v) {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(v);
  } else {
    return static_cast<T>(std::lround(v));
  }
}

}  // namespace

std::string VoxelBox::str() const {
  std::ostringstream s;
  for (int a = 0; a < 3; ++a) {
    s << (a ? ", " : "") << kAxes[a] << " " << lo[static_cast<std::size_t>(a)] << ":"
      << hi[static_cast<std::size_t>(a)];
  }
  return s.str();
}

VoxelBox parse_voxel_box(const std::string& text, const std::string& option) {
  const auto r = parse_ranges(text, option);
  VoxelBox box;
  for (std::size_t a = 0; a < 3; ++a) {
    for (std::size_t e = 0; e < 2; ++e) {
      if (r[a][e] != std::floor(r[a][e]) || std::fabs(r[a][e]) > 1e12) {
        throw ConfigError(option + ": voxel indices must be integers, got '" + text + "'");
      }
    }
    box.lo[a] = static_cast<std::int64_t>(r[a][0]);
    box.hi[a] = static_cast<std::int64_t>(r[a][1]);
  }
  return box;
}

PhysicalBox parse_physical_box(const std::string& text, const std::string& option) {
  const auto r = parse_ranges(text, option);
  PhysicalBox box;
  for (std::size_t a = 0; a < 3; ++a) {
    box.lo[a] = r[a][0];
    box.hi[a] = r[a][1];
  }
  return box;
}

void check_box(const VoxelBox& box, const Shape& shape) {
  for (int a = 0; a < 3; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    const std::int64_t n = extent_of(shape, a);
    if (box.lo[ua] >= box.hi[ua]) {
      throw ConfigError("crop box " + box.str() + " is empty along " + kAxes[a]);
    }
    if (box.lo[ua] < 0 || box.hi[ua] > n) {
      throw ConfigError("crop box " + box.str() + " lies outside the volume (" + shape.str() +
                        ", " + kAxes[a] + " 0:" + std::to_string(n) + ")");
    }
  }
}

VoxelBox voxels_in(const PhysicalBox& box, const Shape& shape, const Spacing& spacing) {
  VoxelBox v;
  for (int a = 0; a < 3; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    const double h = spacing_of(spacing, a);
    if (!(box.lo[ua] < box.hi[ua])) {
      throw ConfigError(std::string("physical box is empty along ") + kAxes[a]);
    }
    // Centres (i + 0.5) h in [lo, hi): i >= lo / h - 0.5 and i < hi / h - 0.5.
    v.lo[ua] = static_cast<std::int64_t>(std::ceil(box.lo[ua] / h - 0.5));
    v.hi[ua] = static_cast<std::int64_t>(std::ceil(box.hi[ua] / h - 0.5));
    const std::int64_t n = extent_of(shape, a);
    std::ostringstream what;
    what << "physical box " << kAxes[a] << " " << box.lo[ua] << ":" << box.hi[ua] << " "
         << spacing.unit;
    if (v.hi[ua] <= 0 || v.lo[ua] >= n) {
      what << " lies outside the volume (" << kAxes[a] << " 0:" << double(n) * h << " "
           << spacing.unit << ")";
      throw ConfigError(what.str());
    }
    if (v.lo[ua] < 0 || v.hi[ua] > n) {
      what << " reaches beyond the volume (" << kAxes[a] << " 0:" << double(n) * h << " "
           << spacing.unit << ")";
      throw ConfigError(what.str());
    }
    if (v.lo[ua] >= v.hi[ua]) {
      what << " holds no voxel centre";
      throw ConfigError(what.str());
    }
  }
  return v;
}

Volume crop(const Volume& volume, const VoxelBox& box) {
  check_box(box, volume.shape());
  const Shape in = volume.shape();
  const Shape out_shape = box.shape();
  Volume out(out_shape, volume.dtype(), volume.spacing());
  const std::size_t elem = dtype_size(volume.dtype());
  const std::size_t row_bytes = static_cast<std::size_t>(out_shape.nx) * elem;
  tbb::parallel_for(std::int64_t(0), out_shape.nz, [&](std::int64_t z) {
    for (std::int64_t y = 0; y < out_shape.ny; ++y) {
      const std::int64_t src = ((z + box.lo[0]) * in.ny + (y + box.lo[1])) * in.nx + box.lo[2];
      const std::int64_t dst = (z * out_shape.ny + y) * out_shape.nx;
      std::memcpy(out.bytes() + static_cast<std::size_t>(dst) * elem,
                  volume.bytes() + static_cast<std::size_t>(src) * elem, row_bytes);
    }
  });
  return out;
}

const char* interpolation_name(Interpolation interpolation) {
  return interpolation == Interpolation::kNearest ? "nearest" : "linear";
}

Interpolation parse_interpolation(const std::string& name) {
  if (name == "nearest") return Interpolation::kNearest;
  if (name == "linear") return Interpolation::kLinear;
  throw ConfigError("unknown interpolation '" + name + "' (expected nearest or linear)");
}

ResampleOptions zoom_grid(const Shape& shape, const Spacing& spacing,
                          const std::array<double, 3>& factor) {
  ResampleOptions o;
  o.spacing = spacing;
  std::int64_t n[3];
  double h[3];
  for (int a = 0; a < 3; ++a) {
    const double f = factor[static_cast<std::size_t>(a)];
    if (!(f > 0) || !std::isfinite(f)) {
      throw ConfigError(std::string("zoom factor along ") + kAxes[a] + " must be positive");
    }
    const std::int64_t in = extent_of(shape, a);
    n[a] = std::max<std::int64_t>(1, std::llround(double(in) * f));
    h[a] = spacing_of(spacing, a) * double(in) / double(n[a]);
  }
  o.shape = {n[0], n[1], n[2]};
  o.spacing.dz = h[0];
  o.spacing.dy = h[1];
  o.spacing.dx = h[2];
  return o;
}

ResampleOptions spacing_grid(const Shape& shape, const Spacing& spacing,
                             const std::array<double, 3>& target) {
  ResampleOptions o;
  o.spacing = spacing;
  std::int64_t n[3];
  for (int a = 0; a < 3; ++a) {
    const double t = target[static_cast<std::size_t>(a)];
    if (!(t > 0) || !std::isfinite(t)) {
      throw ConfigError(std::string("target spacing along ") + kAxes[a] + " must be positive");
    }
    n[a] = std::max<std::int64_t>(
        1, std::llround(double(extent_of(shape, a)) * spacing_of(spacing, a) / t));
  }
  o.shape = {n[0], n[1], n[2]};
  o.spacing.dz = target[0];
  o.spacing.dy = target[1];
  o.spacing.dx = target[2];
  return o;
}

Volume resample(const Volume& volume, const ResampleOptions& options) {
  const Shape in = volume.shape();
  const Shape out_shape = options.shape;
  if (out_shape.nz < 1 || out_shape.ny < 1 || out_shape.nx < 1) {
    throw ConfigError("resample: output shape " + out_shape.str() + " is empty");
  }
  validate_spacing(options.spacing, "resample");
  Volume out(out_shape, volume.dtype(), options.spacing);
  // Per axis: the input coordinate of each output centre.
  std::array<std::vector<double>, 3> u;
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n_out = extent_of(out_shape, a), n_in = extent_of(in, a);
    const double ratio = spacing_of(options.spacing, a) / spacing_of(volume.spacing(), a);
    auto& ua = u[static_cast<std::size_t>(a)];
    ua.resize(static_cast<std::size_t>(n_out));
    for (std::int64_t i = 0; i < n_out; ++i) {
      ua[static_cast<std::size_t>(i)] =
          std::clamp((double(i) + 0.5) * ratio - 0.5, 0.0, double(n_in - 1));
    }
  }
  visit_dtype(volume.dtype(), [&](auto tag) {
    using T = decltype(tag);
    const T* src = volume.data<T>();
    T* dst = out.data<T>();
    if (options.interpolation == Interpolation::kNearest) {
      std::array<std::vector<std::int64_t>, 3> idx;
      for (std::size_t a = 0; a < 3; ++a) {
        idx[a].resize(u[a].size());
        // Round half up: a centre exactly between two input centres takes the upper one.
        for (std::size_t i = 0; i < u[a].size(); ++i) {
          idx[a][i] = static_cast<std::int64_t>(std::floor(u[a][i] + 0.5));
        }
      }
      tbb::parallel_for(std::int64_t(0), out_shape.nz, [&](std::int64_t z) {
        for (std::int64_t y = 0; y < out_shape.ny; ++y) {
          const T* row = src + (idx[0][static_cast<std::size_t>(z)] * in.ny +
                                idx[1][static_cast<std::size_t>(y)]) *
                                   in.nx;
          T* o = dst + (z * out_shape.ny + y) * out_shape.nx;
          for (std::int64_t x = 0; x < out_shape.nx; ++x) o[x] = row[idx[2][std::size_t(x)]];
        }
      });
    } else {
      tbb::parallel_for(std::int64_t(0), out_shape.nz, [&](std::int64_t z) {
        auto split_at = [&](std::size_t axis, std::int64_t i, std::int64_t n, std::int64_t& i0,
                            std::int64_t& i1, double& w) {
          const double c = u[axis][static_cast<std::size_t>(i)];
          i0 = static_cast<std::int64_t>(std::floor(c));
          i1 = std::min(i0 + 1, n - 1);
          w = c - double(i0);
        };
        std::int64_t z0, z1, y0, y1, x0, x1;
        double wz, wy, wx;
        split_at(0, z, in.nz, z0, z1, wz);
        for (std::int64_t y = 0; y < out_shape.ny; ++y) {
          split_at(1, y, in.ny, y0, y1, wy);
          T* o = dst + (z * out_shape.ny + y) * out_shape.nx;
          for (std::int64_t x = 0; x < out_shape.nx; ++x) {
            split_at(2, x, in.nx, x0, x1, wx);
            auto at = [&](std::int64_t zz, std::int64_t yy, std::int64_t xx) {
              return double(src[(zz * in.ny + yy) * in.nx + xx]);
            };
            const double c00 = at(z0, y0, x0) * (1 - wx) + at(z0, y0, x1) * wx;
            const double c01 = at(z0, y1, x0) * (1 - wx) + at(z0, y1, x1) * wx;
            const double c10 = at(z1, y0, x0) * (1 - wx) + at(z1, y0, x1) * wx;
            const double c11 = at(z1, y1, x0) * (1 - wx) + at(z1, y1, x1) * wx;
            const double c0 = c00 * (1 - wy) + c01 * wy, c1 = c10 * (1 - wy) + c11 * wy;
            o[x] = round_to<T>(c0 * (1 - wz) + c1 * wz);
          }
        }
      });
    }
  });
  return out;
}

}  // namespace mesorock::voxel
