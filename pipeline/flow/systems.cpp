#include "pipeline/flow/systems.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "mesorock/errors.h"
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

namespace {

// Index i of an axis of n voxels continued by mirror copies: 0 .. n-1, n-1 .. 0, 0 ..
std::int64_t mirrored(std::int64_t i, std::int64_t n) {
  const std::int64_t p = i % (2 * n);
  return p < n ? p : 2 * n - 1 - p;
}

// The voxel classes of the rock benchmark: 0 pore, 1 wall, 2 grain interior. A solid voxel is
// wall when a pore voxel lies within ceil(thickness / voxel) voxels along every axis (periodic):
// the box neighbourhood rockprep's wall sweep takes (voxel/walls.h wall_layers).
std::vector<std::uint8_t> rock_classes(const sim::SolidMask& g, double thickness) {
  const auto nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  std::int64_t reach[3];
  for (int a = 0; a < 3; ++a)
    reach[a] = static_cast<std::int64_t>(std::ceil(thickness / g.voxel[a] * (1 - 1e-12)));
  std::vector<std::uint8_t> cls(g.solid.size(), 0);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        if (!g.is_solid(i, j, k)) continue;
        bool near = false;
        for (std::int64_t c = -reach[2]; c <= reach[2] && !near; ++c)
          for (std::int64_t b = -reach[1]; b <= reach[1] && !near; ++b)
            for (std::int64_t a = -reach[0]; a <= reach[0] && !near; ++a)
              near = !g.is_solid((i + a + nx) % nx, (j + b + ny) % ny, (k + c + nz) % nz);
        cls[g.index(i, j, k)] = near ? 1 : 2;
      }
  return cls;
}

}  // namespace

BuiltSystem make_rock_benchmark(const sim::SolidMask& image, std::int64_t particles,
                                std::uint64_t seed) {
  constexpr double kFluidDensity = 6.5, kWallDensity = 8, kWallThickness = 1.0;
  image.check("the rock image");
  // Particles per voxel of the image itself decide how many voxels the cube needs.
  const std::vector<std::uint8_t> own = rock_classes(image, kWallThickness);
  const double voxel_volume = image.voxel[0] * image.voxel[1] * image.voxel[2];
  double per_voxel = 0;
  for (std::uint8_t c : own) per_voxel += c == 0 ? kFluidDensity : (c == 1 ? kWallDensity : 0);
  per_voxel *= voxel_volume / static_cast<double>(own.size());
  if (!(per_voxel > 0)) throw ConfigError("the rock image holds no pore voxels");
  const auto edge = std::max<std::int64_t>(
      8, std::llround(std::cbrt(static_cast<double>(particles) / per_voxel)));
  auto mask = std::make_shared<sim::SolidMask>();
  mask->dims = {edge, edge, edge};
  mask->voxel = image.voxel;
  mask->nm_per_rc = image.nm_per_rc;
  mask->solid.resize(static_cast<std::size_t>(edge * edge * edge));
  for (std::int64_t k = 0; k < edge; ++k)
    for (std::int64_t j = 0; j < edge; ++j)
      for (std::int64_t i = 0; i < edge; ++i)
        mask->solid[mask->index(i, j, k)] = image.solid[image.index(
            mirrored(i, image.dims[0]), mirrored(j, image.dims[1]), mirrored(k, image.dims[2]))];
  const std::vector<std::uint8_t> cls = rock_classes(*mask, kWallThickness);

  BuiltSystem s;
  s.model.conservative = sim::ConservativeKind::MDPD;
  s.model.seed = seed;
  const int fluid = s.model.add_type({"fluid", false, {0.02, 0, 0}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {-40, 25, 4.5});
  s.model.set_pair(wall, wall, {-40, 25, 4.5});
  s.model.set_pair(fluid, wall, {-18, 25, 4.5});  // rockprep's default wall affinity
  s.model.wall_model.enabled = true;
  s.model.wall_model.wall_types = 1u << wall;
  s.model.wall_model.wall_density = kWallDensity;
  s.model.solid.mask = mask;
  for (int a = 0; a < 3; ++a) s.box.hi[a] = static_cast<double>(edge) * image.voxel[a];

  // The wall: a simple cubic lattice of spacing n_w^(-1/3) kept in the wall voxels (an even
  // wall density, as rockprep's pre-equilibrated tiles give; random wall particles raise the
  // local density and the run's first steps blow up). The fluid: rejection sampling from one
  // uniform stream, reproducible for a seed.
  std::int64_t next_id = 0;
  const double spacing = 1.0 / std::cbrt(kWallDensity);
  std::int64_t lattice[3];
  for (int a = 0; a < 3; ++a)
    lattice[a] = std::max<std::int64_t>(1, std::llround(s.box.hi[a] / spacing));
  auto voxel_of = [&](const double p[3]) {
    std::int64_t v[3];
    for (int a = 0; a < 3; ++a)
      v[a] = std::min(edge - 1, static_cast<std::int64_t>(p[a] / image.voxel[a]));
    return mask->index(v[0], v[1], v[2]);
  };
  for (std::int64_t k = 0; k < lattice[2]; ++k)
    for (std::int64_t j = 0; j < lattice[1]; ++j)
      for (std::int64_t i = 0; i < lattice[0]; ++i) {
        const double p[3] = {(i + 0.5) * s.box.hi[0] / lattice[0],
                             (j + 0.5) * s.box.hi[1] / lattice[1],
                             (k + 0.5) * s.box.hi[2] / lattice[2]};
        if (cls[voxel_of(p)] == 1) s.particles.add(p[0], p[1], p[2], 0, 0, 0, wall, next_id++);
      }
  std::int64_t pore = 0;
  for (std::uint8_t c : cls) pore += c == 0;
  const auto target = static_cast<std::int64_t>(
      std::llround(kFluidDensity * voxel_volume * static_cast<double>(pore)));
  std::uint64_t draw = 0;
  for (std::int64_t placed = 0; placed < target; ++draw) {
    double p[3];
    for (int a = 0; a < 3; ++a) p[a] = sim::seeded_uniform(seed, 0xc7, draw, a) * s.box.hi[a];
    if (cls[voxel_of(p)] != 0) continue;
    s.particles.add(p[0], p[1], p[2], 0, 0, 0, fluid, next_id++);
    ++placed;
  }
  sim::assign_maxwell_velocities(s.particles, s.model, 1.0, seed);
  s.relax_steps = 100;
  return s;
}

}  // namespace mesorock::pipeline
