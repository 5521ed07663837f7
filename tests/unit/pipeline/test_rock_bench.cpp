// The rock benchmark's system (pipeline/flow/systems.h make_rock_benchmark): built from a
// segmented image, extended by mirror copies, packed as rockprep's permeability layout packs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "pipeline/flow/systems.h"
#include "sim/simulation.h"

namespace {

namespace mp = mesorock::pipeline;
namespace ms = mesorock::sim;

// 16^3 voxels of 0.5 rc: a solid sphere of radius 5 voxels (2.5 rc) off the centre, so its
// mirror copies touch across the faces and the grain has an interior deeper than 1 rc.
ms::SolidMask sphere_image() {
  ms::SolidMask m;
  m.dims = {16, 16, 16};
  m.voxel = {0.5, 0.5, 0.5};
  m.solid.assign(16 * 16 * 16, 0);
  for (std::int64_t k = 0; k < 16; ++k)
    for (std::int64_t j = 0; j < 16; ++j)
      for (std::int64_t i = 0; i < 16; ++i)
        m.solid[m.index(i, j, k)] = std::hypot(i + 0.5 - 10, j + 0.5 - 9, k + 0.5 - 8) < 5;
  return m;
}

// Within 1 rc of a pore voxel: some pore voxel within 2 voxels (1 rc) along each axis.
// The voxel index along axis a of coordinate x (the box starts at 0).
std::int64_t voxel(const ms::SolidMask& g, int a, double x) {
  return std::min<std::int64_t>(g.dims[a] - 1, static_cast<std::int64_t>(x / g.voxel[a]));
}

bool near_pore(const ms::SolidMask& g, std::int64_t i, std::int64_t j, std::int64_t k) {
  for (int c = -2; c <= 2; ++c)
    for (int b = -2; b <= 2; ++b)
      for (int a = -2; a <= 2; ++a)
        if (!g.is_solid((i + a + g.dims[0]) % g.dims[0], (j + b + g.dims[1]) % g.dims[1],
                        (k + c + g.dims[2]) % g.dims[2]))
          return true;
  return false;
}

// Every wall voxel holds one lattice particle (spacing 0.5 rc = the voxel), the pore its fluid.
TEST(RockBench, FluidInThePoreOneWallParticlePerWallVoxelAndTheCountAsAsked) {
  const ms::SolidMask image = sphere_image();
  const mp::BuiltSystem s = mp::make_rock_benchmark(image, 60000, 5);
  ASSERT_TRUE(s.model.solid.mask);
  const ms::SolidMask& g = *s.model.solid.mask;
  EXPECT_EQ(g.dims[0], g.dims[1]);
  EXPECT_GT(g.dims[0], 16);  // extended beyond the image
  // The image's pattern repeats mirrored: voxel 16 + i is voxel 15 - i.
  for (std::int64_t i = 0; i < 8 && 16 + i < g.dims[0]; ++i)
    EXPECT_EQ(g.is_solid(16 + i, 3, 4), image.is_solid(15 - i, 3, 4)) << i;
  const std::int64_t n = static_cast<std::int64_t>(s.particles.size());
  EXPECT_NEAR(static_cast<double>(n), 60000.0, 0.25 * 60000.0);
  const std::uint32_t frozen = s.model.frozen_mask();
  ASSERT_EQ(frozen, 2u);  // type 1, the wall
  EXPECT_TRUE(s.model.wall_model.enabled);
  std::int64_t fluid = 0, wall = 0;
  for (std::int64_t p = 0; p < n; ++p) {
    const std::int64_t i = voxel(g, 0, s.particles.x[p]), j = voxel(g, 1, s.particles.y[p]),
                       k = voxel(g, 2, s.particles.z[p]);
    if (s.particles.type[p] == 0) {
      ++fluid;
      ASSERT_FALSE(g.is_solid(i, j, k)) << "fluid particle " << p << " in a solid voxel";
    } else {
      ++wall;
      ASSERT_TRUE(g.is_solid(i, j, k)) << "wall particle " << p << " in a pore voxel";
      ASSERT_TRUE(near_pore(g, i, j, k)) << "wall particle " << p << " deeper than 1 rc";
    }
  }
  // Densities: 6.5 in the pore (the count is rounded, not sampled), 8 in the wall shell (a
  // lattice of spacing 0.5 rc: one particle per wall voxel of 0.5 rc here).
  double pore = 0;
  for (std::uint8_t b : g.solid) pore += b == 0;
  pore *= g.voxel[0] * g.voxel[1] * g.voxel[2];
  EXPECT_NEAR(static_cast<double>(fluid) / pore, 6.5, 0.01);
  std::int64_t wall_voxels = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        wall_voxels += g.is_solid(i, j, k) && near_pore(g, i, j, k);
  EXPECT_GT(wall, 0);
  EXPECT_EQ(wall, wall_voxels);
  // The same seed gives the same particles.
  const mp::BuiltSystem again = mp::make_rock_benchmark(image, 60000, 5);
  ASSERT_EQ(again.particles.size(), s.particles.size());
  EXPECT_EQ(again.particles.x, s.particles.x);
}

// It runs as the benchmark runs it (relax at dt = 0.002, then dt = 0.01): finite, and no fluid
// ends in the solid.
TEST(RockBench, ShortRunStaysFiniteAndOutOfTheSolid) {
  const mp::BuiltSystem s = mp::make_rock_benchmark(sphere_image(), 20000, 3);
  ASSERT_EQ(s.relax_steps, 100u);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, s.relax_dt);
  sim->run(s.relax_steps);
  sim->set_dt(0.01);
  sim->run(50);
  EXPECT_TRUE(std::isfinite(sim->kinetic_temperature()));
  const ms::ParticleSet p = sim->particles();
  const ms::SolidMask& g = *s.model.solid.mask;
  for (std::size_t q = 0; q < p.size(); ++q) {
    if (p.type[q] != 0) continue;
    ASSERT_FALSE(g.is_solid(voxel(g, 0, p.x[q]), voxel(g, 1, p.y[q]), voxel(g, 2, p.z[q]))) << q;
  }
}

}  // namespace
