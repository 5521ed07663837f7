#include "sim/init.h"

#include <Random123/philox.h>

#include <cmath>

#include "mesorock/errors.h"

namespace mesorock::sim {

double seeded_uniform(std::uint64_t seed, std::uint64_t stream, std::uint64_t index,
                      std::uint32_t component) {
  r123::Philox4x32 rng;
  r123::Philox4x32::ctr_type ctr = {{static_cast<std::uint32_t>(index),
                                     static_cast<std::uint32_t>(index >> 32), component,
                                     static_cast<std::uint32_t>(stream)}};
  r123::Philox4x32::key_type key = {
      {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)}};
  const auto out = rng(ctr, key);
  // 53 random bits -> [0, 1).
  const std::uint64_t bits =
      (static_cast<std::uint64_t>(out.v[0]) << 21) ^ (static_cast<std::uint64_t>(out.v[1]) >> 11);
  return static_cast<double>(bits & ((1ull << 53) - 1)) * (1.0 / 9007199254740992.0);
}

double seeded_normal(std::uint64_t seed, std::uint64_t stream, std::uint64_t index,
                     std::uint32_t component) {
  const double u1 = seeded_uniform(seed, stream, index, 2 * component);
  const double u2 = seeded_uniform(seed, stream, index, 2 * component + 1);
  return std::sqrt(-2.0 * std::log(1.0 - u1)) * std::cos(6.283185307179586 * u2);
}

namespace {
constexpr std::uint64_t kStreamPosition = 0x706f73;  // "pos"
constexpr std::uint64_t kStreamVelocity = 0x76656c;  // "vel"
}  // namespace

void fill_random(ParticleSet& p, std::int32_t type, const std::array<double, 3>& lo,
                 const std::array<double, 3>& hi, std::int64_t count, std::uint64_t seed,
                 std::int64_t& next_id) {
  if (count < 0) throw ConfigError("particle count must be >= 0");
  p.reserve(p.size() + static_cast<size_t>(count));
  for (std::int64_t k = 0; k < count; ++k) {
    const std::int64_t pid = next_id++;
    double c[3];
    for (int a = 0; a < 3; ++a) {
      const double u = seeded_uniform(seed, kStreamPosition, static_cast<std::uint64_t>(pid),
                                      static_cast<std::uint32_t>(a));
      c[a] = lo[a] + u * (hi[a] - lo[a]);
      if (c[a] >= hi[a]) c[a] = std::nextafter(hi[a], lo[a]);
    }
    p.add(c[0], c[1], c[2], 0, 0, 0, type, pid);
  }
}

void fill_lattice(ParticleSet& p, std::int32_t type, const std::array<double, 3>& lo,
                  const std::array<double, 3>& hi, double density, std::int64_t& next_id) {
  if (!(density > 0)) throw ConfigError("lattice density must be positive");
  const double spacing = std::cbrt(1.0 / density);
  int n[3];
  double step[3];
  for (int a = 0; a < 3; ++a) {
    const double len = hi[a] - lo[a];
    n[a] = std::max(1, static_cast<int>(std::lround(len / spacing)));
    step[a] = len / n[a];
  }
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        p.add(lo[0] + (i + 0.5) * step[0], lo[1] + (j + 0.5) * step[1], lo[2] + (k + 0.5) * step[2],
              0, 0, 0, type, next_id++);
}

void assign_maxwell_velocities(ParticleSet& p, const Model& model, double kBT, std::uint64_t seed) {
  const double s = std::sqrt(kBT);
  double sum[3] = {0, 0, 0};
  size_t mobile = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    if (model.types[static_cast<size_t>(p.type[i])].frozen) {
      p.vx[i] = p.vy[i] = p.vz[i] = 0;
      continue;
    }
    const auto pid = static_cast<std::uint64_t>(p.id[i]);
    p.vx[i] = s * seeded_normal(seed, kStreamVelocity, pid, 0);
    p.vy[i] = s * seeded_normal(seed, kStreamVelocity, pid, 1);
    p.vz[i] = s * seeded_normal(seed, kStreamVelocity, pid, 2);
    sum[0] += p.vx[i];
    sum[1] += p.vy[i];
    sum[2] += p.vz[i];
    ++mobile;
  }
  if (mobile == 0) return;
  for (double& v : sum) v /= static_cast<double>(mobile);
  for (size_t i = 0; i < p.size(); ++i) {
    if (model.types[static_cast<size_t>(p.type[i])].frozen) continue;
    p.vx[i] -= sum[0];
    p.vy[i] -= sum[1];
    p.vz[i] -= sum[2];
  }
}

}  // namespace mesorock::sim
