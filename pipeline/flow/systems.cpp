#include "pipeline/flow/systems.h"

#include <cmath>

#include "sim/init.h"

namespace mesorock::pipeline {

namespace {
BuiltSystem make_bulk(sim::ConservativeKind kind, double A, double B, double rd, double gamma,
                      double rho, const double L[3], std::uint64_t seed,
                      sim::DensityKernelKind kernel) {
  BuiltSystem s;
  s.model.conservative = kind;
  s.model.density_kernel = kernel;
  s.model.rd = rd;
  s.model.seed = seed;
  s.model.thermostat = gamma > 0;
  const int t = s.model.add_type({"fluid", false, {0, 0, 0}});
  s.model.set_pair(t, t, {A, B, gamma});
  s.box.lo = {0, 0, 0};
  s.box.hi = {L[0], L[1], L[2]};
  const auto count = static_cast<std::int64_t>(std::llround(rho * L[0] * L[1] * L[2]));
  std::int64_t next_id = 0;
  sim::fill_random(s.particles, t, s.box.lo, s.box.hi, count, seed, next_id);
  sim::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}
}  // namespace

BuiltSystem make_bulk_mdpd(double A, double B, double rd, double gamma, double rho,
                           const double L[3], std::uint64_t seed, sim::DensityKernelKind kernel) {
  return make_bulk(sim::ConservativeKind::MDPD, A, B, rd, gamma, rho, L, seed, kernel);
}

BuiltSystem make_bulk_dpd(double a, double gamma, double rho, const double L[3],
                          std::uint64_t seed) {
  return make_bulk(sim::ConservativeKind::DPD, a, 0.0, 0.75, gamma, rho, L, seed,
                   sim::DensityKernelKind::Warren);
}

BuiltSystem make_porous_benchmark(int nx, int nz, std::uint64_t seed) {
  constexpr double kCellX = 16, kCellY = 2, kCellZ = 16;
  constexpr double kOuter = 7, kInner = 6, kWallDensity = 8, kFluidDensity = 6.2;
  BuiltSystem s;
  s.model.conservative = sim::ConservativeKind::MDPD;
  s.model.seed = seed;
  const int fluid = s.model.add_type({"fluid", false, {0, 0, 0.02}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  for (int a : {fluid, wall})
    for (int b : {fluid, wall}) s.model.set_pair(a, b, {-40, 25, 4.5});
  s.box.hi = {kCellX * nx, kCellY, kCellZ * nz};
  const double cell_volume = kCellX * kCellY * kCellZ;
  const double ring_volume = M_PI * (kOuter * kOuter - kInner * kInner) * kCellY;
  const double fluid_volume = cell_volume - M_PI * kOuter * kOuter * kCellY;
  // Per cell: about 653 wall and 1263 fluid particles (the paper: 666 and 1296); rejection
  // sampling from one uniform stream keeps it reproducible.
  const auto wall_target = static_cast<std::int64_t>(std::llround(kWallDensity * ring_volume));
  const auto fluid_target = static_cast<std::int64_t>(std::llround(kFluidDensity * fluid_volume));
  std::int64_t next_id = 0;
  std::uint64_t draw = 0;
  for (int k = 0; k < nz; ++k) {
    for (int i = 0; i < nx; ++i) {
      const double shift = (k % 2 == 1) ? 0.5 * kCellX : 0.0;
      const double cx = std::fmod(kCellX * i + 0.5 * kCellX + shift, kCellX * nx);
      const double cz = kCellZ * k + 0.5 * kCellZ;
      auto place = [&](std::int64_t target, int type, bool in_ring) {
        std::int64_t placed = 0;
        while (placed < target) {
          const double u = sim::seeded_uniform(seed, 0xb3, draw, 0);
          const double v = sim::seeded_uniform(seed, 0xb3, draw, 1);
          const double w = sim::seeded_uniform(seed, 0xb3, draw, 2);
          ++draw;
          const double dx = (u - 0.5) * kCellX, dz = (w - 0.5) * kCellZ;
          const double r = std::sqrt(dx * dx + dz * dz);
          const bool ok = in_ring ? (r > kInner && r < kOuter) : (r >= kOuter);
          if (!ok) continue;
          double x = cx + dx;
          if (x >= kCellX * nx) x -= kCellX * nx;
          if (x < 0) x += kCellX * nx;
          s.particles.add(x, v * kCellY, cz + dz, 0, 0, 0, type, next_id++);
          ++placed;
        }
      };
      place(wall_target, wall, true);
      place(fluid_target, fluid, false);
    }
  }
  sim::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  return s;
}

}  // namespace mesorock::pipeline
