#include "pipeline/flow/phase_placement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "mesorock/distance_transform.h"
#include "mesorock/errors.h"

namespace mesorock::pipeline {

Placement parse_placement(const std::string& text) {
  if (text == "random") return Placement::Random;
  if (text == "drainage") return Placement::Drainage;
  throw ConfigError("relperm: placement must be random or drainage (got '" + text + "')");
}

std::string to_string(Placement p) {
  return p == Placement::Random ? "random" : "drainage";
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// In place: squared distances (rc^2) from every voxel to the nearest voxel whose value is 0 (the
// seeds; every other voxel starts at +infinity), voxel centre to voxel centre. A periodic axis is
// transformed on three copies of each line, the middle one kept: every seed within a period.
void squared_distance(std::vector<float>& d, const sim::SolidMask& g,
                      const std::array<bool, 3>& periodic) {
  const std::int64_t n[3] = {g.dims[0], g.dims[1], g.dims[2]};
  const std::int64_t stride[3] = {1, n[0], n[0] * n[1]};
  DistanceLineScratch scratch;
  std::vector<float> line;
  for (int a = 0; a < 3; ++a) {
    const std::int64_t len = n[a], copies = periodic[static_cast<size_t>(a)] ? 3 : 1;
    scratch.reserve(len * copies);
    line.resize(static_cast<size_t>(len * copies));
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    for (std::int64_t j = 0; j < n[c]; ++j)
      for (std::int64_t i = 0; i < n[b]; ++i) {
        float* start = d.data() + i * stride[b] + j * stride[c];
        for (std::int64_t r = 0; r < copies; ++r)
          for (std::int64_t q = 0; q < len; ++q)
            line[static_cast<size_t>(r * len + q)] = start[q * stride[a]];
        squared_distance_line(line.data(), len * copies, 1, g.voxel[static_cast<size_t>(a)],
                              scratch);
        const std::int64_t from = copies == 3 ? len : 0;
        for (std::int64_t q = 0; q < len; ++q)
          start[q * stride[a]] = line[static_cast<size_t>(from + q)];
      }
  }
}

// splitmix64: a well-mixed 64-bit hash, the same on every platform.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The grid voxel a point lies in: wrapped along periodic axes, clamped to the grid elsewhere.
std::size_t voxel_of(const sim::SolidMask& g, const std::array<bool, 3>& periodic, double x,
                     double y, double z) {
  const double p[3] = {x, y, z};
  std::int64_t c[3];
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<size_t>(a);
    const std::int64_t n = g.dims[k];
    auto i = static_cast<std::int64_t>(std::floor((p[a] - g.origin[k]) / g.voxel[k]));
    if (periodic[k])
      i = ((i % n) + n) % n;
    else
      i = std::clamp<std::int64_t>(i, 0, n - 1);
    c[a] = i;
  }
  return g.index(c[0], c[1], c[2]);
}

}  // namespace

DrainageMap drainage_map(const sim::SolidMask& g, const std::array<bool, 3>& periodic,
                         const std::function<void(int, int)>& on_radius) {
  g.check("relperm: solid grid");
  const auto nv = static_cast<std::size_t>(g.voxels());
  const std::size_t solid = static_cast<std::size_t>(std::count(g.solid.begin(), g.solid.end(), 1));
  if (solid == 0 || solid == nv)
    throw ConfigError(std::string("relperm: the solid grid has ") +
                      (solid == 0 ? "no solid voxel" : "no pore voxel") +
                      ", so pore sizes are not defined (use the random placement)");
  DrainageMap m;
  m.dims = g.dims;
  // Distance of every voxel to the solid.
  std::vector<float> d2(nv);
  for (std::size_t v = 0; v < nv; ++v) d2[v] = g.solid[v] ? 0.0f : kInf;
  squared_distance(d2, g, periodic);
  m.distance.resize(nv);
  float largest = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    m.distance[v] = std::sqrt(d2[v]);
    largest = std::max(largest, m.distance[v]);
  }
  // Openings at R_k = k h / 2, k = 2 (every pore voxel: its distance is at least h) up to the
  // largest distance; a voxel's radius is the largest R_k whose opening holds it.
  const double h = std::min({g.voxel[0], g.voxel[1], g.voxel[2]});
  const int K = std::max(2, static_cast<int>(std::floor(largest / (h / 2) + 1e-6)));
  m.radius.assign(nv, 0.0f);
  std::vector<float> reach(nv);
  for (int k = 2; k <= K; ++k) {
    const float R = static_cast<float>(k * h / 2);
    for (std::size_t v = 0; v < nv; ++v)
      reach[v] = !g.solid[v] && m.distance[v] >= R * (1 - 1e-6f) ? 0.0f : kInf;
    squared_distance(reach, g, periodic);
    for (std::size_t v = 0; v < nv; ++v)
      if (!g.solid[v] && reach[v] < R * R) m.radius[v] = R;
    if (on_radius) on_radius(k - 1, K - 1);
  }
  m.largest_radius = *std::max_element(m.radius.begin(), m.radius.end());
  return m;
}

PlacementResult place_phases(sim::ParticleSet& p, int wetting, int nonwetting, double saturation,
                             Placement rule, std::uint64_t seed, const DrainageMap* map,
                             const sim::SolidMask* mask, const std::array<bool, 3>& periodic) {
  if (!(saturation >= 0 && saturation <= 1))
    throw ConfigError("relperm: a wetting saturation must lie in [0, 1] (got " +
                      std::to_string(saturation) + ")");
  if (rule == Placement::Drainage && (!map || !mask))
    throw ConfigError(
        "relperm: the drainage placement needs the sample's solid grid ([solid] in "
        "the scene, as rockprep run --layout permeability writes it)");
  std::vector<std::size_t> fluid;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == wetting) fluid.push_back(i);
  PlacementResult r;
  r.fluid = fluid.size();
  r.nonwetting =
      static_cast<std::size_t>(std::llround((1 - saturation) * static_cast<double>(fluid.size())));
  // Order the candidates, the first ones turn non-wetting.
  if (rule == Placement::Random) {
    std::vector<std::pair<std::uint64_t, std::size_t>> key(fluid.size());
    for (std::size_t k = 0; k < fluid.size(); ++k)
      key[k] = {mix(seed ^ mix(static_cast<std::uint64_t>(p.id[fluid[k]]))), fluid[k]};
    std::sort(key.begin(), key.end());
    for (std::size_t k = 0; k < fluid.size(); ++k) fluid[k] = key[k].second;
  } else {
    std::vector<std::pair<float, float>> at(p.size());
    for (std::size_t i : fluid) {
      const std::size_t v = voxel_of(*mask, periodic, p.x[i], p.y[i], p.z[i]);
      at[i] = {map->radius[v], map->distance[v]};
    }
    std::stable_sort(fluid.begin(), fluid.end(), [&](std::size_t a, std::size_t b) {
      return at[a] > at[b];  // largest radius, then farthest from the solid; index order last
    });
    if (r.nonwetting > 0) r.entry_radius = at[fluid[r.nonwetting - 1]].first;
  }
  for (std::size_t k = 0; k < r.nonwetting; ++k) p.type[fluid[k]] = nonwetting;
  r.saturation = fluid.empty()
                     ? 0.0
                     : 1.0 - static_cast<double>(r.nonwetting) / static_cast<double>(fluid.size());
  return r;
}

}  // namespace mesorock::pipeline
