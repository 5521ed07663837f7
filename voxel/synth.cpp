#include "voxel/synth.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "mesorock/errors.h"
#include "voxel/filters.h"

namespace mesorock::voxel {
namespace {

constexpr std::uint8_t kPoreCode = static_cast<std::uint8_t>(Phase::kPore);
constexpr std::uint8_t kOrganicCode = static_cast<std::uint8_t>(Phase::kOrganic);
constexpr std::uint8_t kInorganicCode = static_cast<std::uint8_t>(Phase::kInorganic);
constexpr std::uint8_t kOrganicPoreCode = static_cast<std::uint8_t>(Phase::kOrganicPore);

// Uniform in [0, 1) from the top 53 bits (the std distributions are implementation-defined).
double uniform(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

// Uniform integer in [0, n) by multiply-shift (Lemire), without modulo bias worth mentioning.
std::int64_t uniform_index(std::mt19937_64& rng, std::int64_t n) {
  return static_cast<std::int64_t>(
      (static_cast<unsigned __int128>(rng()) * static_cast<unsigned __int128>(n)) >> 64);
}

// Recodes voxels of code `host` inside the physical sphere of radius rx * dx centred at voxel
// coordinates (cz, cy, cx) to `code`; returns how many changed.
std::int64_t paint_sphere(Volume& truth, double cz, double cy, double cx, double rx,
                          std::uint8_t host, std::uint8_t code) {
  const Shape s = truth.shape();
  const Spacing& sp = truth.spacing();
  const double ry = rx * sp.dx / sp.dy, rz = rx * sp.dx / sp.dz;
  std::uint8_t* v = truth.data<std::uint8_t>();
  std::int64_t changed = 0;
  const auto z0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cz - rz)));
  const auto z1 = std::min<std::int64_t>(s.nz - 1, static_cast<std::int64_t>(std::floor(cz + rz)));
  for (std::int64_t z = z0; z <= z1; ++z) {
    const double tz = (static_cast<double>(z) - cz) / rz;
    const double left_z = 1.0 - tz * tz;
    if (left_z < 0) continue;
    const double half_y = ry * std::sqrt(left_z);
    const auto y0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cy - half_y)));
    const auto y1 =
        std::min<std::int64_t>(s.ny - 1, static_cast<std::int64_t>(std::floor(cy + half_y)));
    for (std::int64_t y = y0; y <= y1; ++y) {
      const double ty = (static_cast<double>(y) - cy) / ry;
      const double left = left_z - ty * ty;
      if (left < 0) continue;
      const double half_x = rx * std::sqrt(left);
      const auto x0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(cx - half_x)));
      const auto x1 =
          std::min<std::int64_t>(s.nx - 1, static_cast<std::int64_t>(std::floor(cx + half_x)));
      std::uint8_t* row = v + (z * s.ny + y) * s.nx;
      for (std::int64_t x = x0; x <= x1; ++x) {
        if (row[x] == host) {
          row[x] = code;
          ++changed;
        }
      }
    }
  }
  return changed;
}

// Places spheres centred on random voxels of code `host` until `target` voxels carry `code`.
void place_pores(Volume& truth, std::mt19937_64& rng, std::int64_t target, double radius,
                 std::uint8_t host, std::uint8_t code, const char* what) {
  const std::int64_t n = truth.voxels();
  const std::uint8_t* v = truth.data<std::uint8_t>();
  std::int64_t placed = 0, misses = 0;
  while (placed < target) {
    const std::int64_t i = uniform_index(rng, n);
    const double r = radius * (0.5 + uniform(rng));
    if (v[i] != host) {
      if (++misses > 200000000) {
        throw ConfigError(std::string("synthetic shale: cannot place the ") + what +
                          " pores (host phase too small)");
      }
      continue;
    }
    const std::int64_t x = i % truth.shape().nx, y = (i / truth.shape().nx) % truth.shape().ny,
                       z = i / truth.shape().slice_voxels();
    placed += paint_sphere(truth, double(z), double(y), double(x), r, host, code);
  }
}

}  // namespace

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

ShaleSample make_shale(const ShaleOptions& o) {
  const Shape s = o.shape;
  validate_spacing(o.spacing, "synthetic shale");
  if (s.nz < 1 || s.ny < 1 || s.nx < 1) throw ConfigError("synthetic shale: empty shape");
  if (!(o.porosity >= 0 && o.porosity <= 0.6)) {
    throw ConfigError("synthetic shale: porosity must be 0 to 0.6");
  }
  if (!(o.organic_fraction >= 0 && o.organic_fraction <= 0.9)) {
    throw ConfigError("synthetic shale: organic fraction must be 0 to 0.9");
  }
  if (!(o.matrix_pore_share >= 0 && o.matrix_pore_share <= 1)) {
    throw ConfigError("synthetic shale: matrix pore share must be 0 to 1");
  }
  if (!(o.blob_radius >= 0.5 && o.blob_radius <= 1000) || o.pore_radius < 0) {
    throw ConfigError("synthetic shale: blob radius must be 0.5 to 1000 voxels");
  }
  if (!(o.noise >= 0) || !(o.blur >= 0)) {
    throw ConfigError("synthetic shale: noise and blur must not be negative");
  }
  if (o.dtype != DType::kUInt8 && o.dtype != DType::kUInt16) {
    throw ConfigError("synthetic shale: dtype must be uint8 or uint16");
  }
  const double hosted = o.porosity * (1 - o.matrix_pore_share);
  const double in_matrix = o.porosity * o.matrix_pore_share;
  if (hosted > 0.8 * o.organic_fraction + 1e-12 ||
      in_matrix > 0.8 * (1 - o.organic_fraction) + 1e-12) {
    throw ConfigError("synthetic shale: porosity " + std::to_string(o.porosity) +
                      " does not fit in the organic fraction " +
                      std::to_string(o.organic_fraction) + " (at most 80% of a host is pore)");
  }

  ShaleSample sample;
  sample.truth = Volume(s, DType::kUInt8, o.spacing);
  Volume& truth = sample.truth;
  std::fill(truth.data<std::uint8_t>(), truth.data<std::uint8_t>() + truth.voxels(),
            kInorganicCode);
  std::mt19937_64 rng(o.seed);
  const double n = static_cast<double>(s.voxels());

  // Organic blobs: centres anywhere in the box, radii uniform in [0.5, 1.5) x the mean.
  const auto organic_target = static_cast<std::int64_t>(std::llround(o.organic_fraction * n));
  std::int64_t organic = 0;
  while (organic < organic_target) {
    const double cz = uniform(rng) * double(s.nz), cy = uniform(rng) * double(s.ny),
                 cx = uniform(rng) * double(s.nx);
    const double r = o.blob_radius * (0.5 + uniform(rng));
    organic += paint_sphere(truth, cz, cy, cx, r, kInorganicCode, kOrganicCode);
  }
  const double pore_radius = o.pore_radius > 0 ? o.pore_radius : o.blob_radius / 3;
  place_pores(truth, rng, static_cast<std::int64_t>(std::llround(hosted * n)), pore_radius,
              kOrganicCode, kOrganicPoreCode, "organic-hosted");
  place_pores(truth, rng, static_cast<std::int64_t>(std::llround(in_matrix * n)), pore_radius,
              kInorganicCode, kPoreCode, "matrix");
  sample.truth_counts = count_phases(truth);

  // Grey image: phase means, optional blur, then noise.
  sample.grey = Volume(s, o.dtype, o.spacing);
  const double scale = o.dtype == DType::kUInt16 ? 257.0 : 1.0;
  const double top = o.dtype == DType::kUInt16 ? 65535.0 : 255.0;
  double mean[kPhaseCount] = {0, o.grey[0], o.grey[1], o.grey[2], o.grey[0]};
  for (double& m : mean) m = std::clamp(std::round(m * scale), 0.0, top);
  visit_dtype(o.dtype, [&](auto tag) {
    using T = decltype(tag);
    T* g = sample.grey.data<T>();
    const std::uint8_t* t = truth.data<std::uint8_t>();
    tbb::parallel_for(std::int64_t(0), s.voxels(),
                      [&](std::int64_t i) { g[i] = static_cast<T>(mean[t[i]]); });
    if (o.blur > 0) gaussian_filter(sample.grey, isotropic_gaussian(o.blur));
    if (o.noise > 0) {
      const std::uint64_t key = mix64(o.seed ^ 0x6e6f697365ull);  // "noise"
      const double sigma = o.noise * scale;
      tbb::parallel_for(std::int64_t(0), s.nz, [&](std::int64_t z) {
        for (std::int64_t i = z * s.slice_voxels(); i < (z + 1) * s.slice_voxels(); ++i) {
          // Box-Muller from two hashed uniforms: u1 in (0, 1], u2 in [0, 1).
          const auto c = static_cast<std::uint64_t>(i) * 2;
          const double u1 = static_cast<double>((mix64(key + c) >> 11) + 1) * 0x1.0p-53;
          const double u2 = static_cast<double>(mix64(key + c + 1) >> 11) * 0x1.0p-53;
          const double normal = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
          g[i] = static_cast<T>(std::clamp(std::round(double(g[i]) + sigma * normal), 0.0, top));
        }
      });
    }
  });
  return sample;
}

}  // namespace mesorock::voxel
