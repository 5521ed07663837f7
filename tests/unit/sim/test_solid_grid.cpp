// The solid grid (sim/solid_grid.h): the voxel lookup is the staircase itself, the depth is the
// exact distance to the nearest pore voxel (against brute force), solid.h5 round-trips and
// refuses bad files, and on every backend a particle that drifts into a solid voxel is sent
// back, a fluid pressed onto a one-voxel grain stays out of it with the bounce and leaks into it
// without (the leak invariant counts it, the watchdog stops it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "backends.h"
#include "mesorock/errors.h"
#include "sim/init.h"
#include "sim/simulation.h"
#include "sim/solid_grid.h"

namespace fs = std::filesystem;
namespace ms = mesorock::sim;
using mesorock::test::OnEveryBackend;

namespace {

ms::SolidMask empty_mask(int nx, int ny, int nz, double voxel) {
  ms::SolidMask m;
  m.dims = {nx, ny, nz};
  m.voxel = {voxel, voxel, voxel};
  m.solid.assign(static_cast<size_t>(nx * ny * nz), 0);
  return m;
}

ms::SolidView<double> view_of(const ms::SolidMask& m, bool periodic, double stop_depth = 0.5) {
  ms::SolidView<double> v;
  v.solid = m.solid.data();
  for (int a = 0; a < 3; ++a) {
    v.dims[a] = static_cast<int>(m.dims[a]);
    v.origin[a] = m.origin[a];
    v.voxel[a] = m.voxel[a];
    v.inv_voxel[a] = 1 / m.voxel[a];
    v.periodic[a] = periodic;
    v.reach[a] = static_cast<int>(std::ceil(stop_depth / m.voxel[a])) + 1;
  }
  v.stop_depth = stop_depth;
  return v;
}

TEST(SolidView, TheLookupIsTheVoxelStaircase) {
  ms::SolidMask m = empty_mask(4, 4, 4, 0.5);
  m.solid[m.index(1, 2, 3)] = 1;  // one solid voxel: [0.5, 1) x [1, 1.5) x [1.5, 2)
  const ms::SolidView<double> v = view_of(m, true);
  EXPECT_TRUE(v.in_solid(0.75, 1.25, 1.75));
  EXPECT_TRUE(v.in_solid(0.5, 1.0, 1.5));               // the lower faces belong to the voxel
  EXPECT_FALSE(v.in_solid(0.4999999, 1.25, 1.75));      // just outside
  EXPECT_FALSE(v.in_solid(1.0, 1.25, 1.75));            // the upper face belongs to the next
  EXPECT_TRUE(v.in_solid(0.75 + 2.0, 1.25, 1.75 - 2));  // periodic images
  const ms::SolidView<double> open = view_of(m, false);
  EXPECT_FALSE(open.in_solid(0.75 + 2.0, 1.25, 1.75));  // outside a non-periodic grid: pore
  EXPECT_FALSE(open.in_solid(std::numeric_limits<double>::quiet_NaN(), 1.25, 1.75));
}

// Brute force: the distance from p to the nearest pore voxel cube over every periodic image.
double brute_depth(const ms::SolidMask& m, const double p[3], double limit) {
  bool inside = false;
  {
    int c[3];
    for (int a = 0; a < 3; ++a) {
      c[a] = static_cast<int>(std::floor(p[a] / m.voxel[a]));
      c[a] = ((c[a] % m.dims[a]) + m.dims[a]) % m.dims[a];
    }
    inside = m.is_solid(c[0], c[1], c[2]);
  }
  if (!inside) return 0;
  double best = limit;
  for (int k = 0; k < m.dims[2]; ++k)
    for (int j = 0; j < m.dims[1]; ++j)
      for (int i = 0; i < m.dims[0]; ++i) {
        if (m.is_solid(i, j, k)) continue;
        const int idx[3] = {i, j, k};
        for (int sx = -1; sx <= 1; ++sx)
          for (int sy = -1; sy <= 1; ++sy)
            for (int sz = -1; sz <= 1; ++sz) {
              const int shift[3] = {sx, sy, sz};
              double d2 = 0;
              for (int a = 0; a < 3; ++a) {
                const double L = m.dims[a] * m.voxel[a];
                const double lo = idx[a] * m.voxel[a] + shift[a] * L, hi = lo + m.voxel[a];
                const double out = std::max(lo - p[a], p[a] - hi);
                if (out > 0) d2 += out * out;
              }
              best = std::min(best, std::sqrt(d2));
            }
      }
  return best;
}

TEST(SolidView, DepthIsTheExactDistanceToThePore) {
  // A random grain structure (about half solid) on a periodic 12^3 grid of 0.25 rc voxels.
  ms::SolidMask m = empty_mask(12, 12, 12, 0.25);
  std::mt19937_64 gen(5);
  for (auto& b : m.solid) b = gen() % 100 < 55;
  for (int k = 2; k < 11; ++k)  // and one thick block, for points deeper than the search
    for (int j = 2; j < 11; ++j)
      for (int i = 2; i < 11; ++i) m.solid[m.index(i, j, k)] = 1;
  const ms::SolidView<double> v = view_of(m, true, 0.5);
  const double limit = v.reach[0] * 0.25;
  std::uniform_real_distribution<double> u(0, 3.0);
  int inside = 0, deep = 0;
  for (int n = 0; n < 3000; ++n) {
    const double p[3] = {u(gen), u(gen), u(gen)};
    const double d = v.depth(p[0], p[1], p[2]);
    const double want = brute_depth(m, p, limit);
    ASSERT_NEAR(d, want, 1e-12) << p[0] << " " << p[1] << " " << p[2];
    inside += d > 0;
    deep += d > 0.2;
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(deep, 5);                              // the block's interior was sampled
  EXPECT_EQ(v.depth(1.625, 1.625, 1.625), limit);  // the block's centre: beyond the search
}

// pore_within (which marks the buried frozen particles, StepView::buried_part): some pore voxel
// closer than d exactly when the brute-force depth is below d, at the radii a run uses.
TEST(SolidView, PoreWithinIsTheDepthBelowTheRadius) {
  ms::SolidMask m = empty_mask(12, 12, 12, 0.25);
  std::mt19937_64 gen(9);
  for (auto& b : m.solid) b = gen() % 100 < 55;
  for (int k = 1; k < 12; ++k)  // a thick block, so that some points are buried deeper than rc
    for (int j = 1; j < 12; ++j)
      for (int i = 1; i < 12; ++i) m.solid[m.index(i, j, k)] = 1;
  const ms::SolidView<double> v = view_of(m, true);
  std::uniform_real_distribution<double> u(0, 3.0);
  int buried[3] = {0, 0, 0};
  const double radii[3] = {0.3, 0.6, 1.001};
  for (int n = 0; n < 2000; ++n) {
    const double p[3] = {u(gen), u(gen), u(gen)};
    const double depth = brute_depth(m, p, 10.0);
    for (int r = 0; r < 3; ++r) {
      ASSERT_EQ(v.pore_within(p[0], p[1], p[2], radii[r]), depth < radii[r])
          << p[0] << " " << p[1] << " " << p[2] << ", radius " << radii[r];
      buried[r] += depth >= radii[r];
    }
  }
  EXPECT_GT(buried[2], 20);  // deeper than rc: sampled
  EXPECT_GT(buried[0], buried[2]);
}

TEST(SolidFile, RoundTripsAndRefusesBadFiles) {
  const fs::path dir = fs::temp_directory_path() / "mesorock_solid_file_test";
  fs::create_directories(dir);
  ms::SolidMask m = empty_mask(5, 3, 2, 0.5);
  m.voxel = {0.5, 0.5, 0.75};
  m.origin = {1, 2, 3};
  m.nm_per_rc = 10.69;
  m.solid[m.index(4, 2, 1)] = 1;
  m.solid[m.index(0, 1, 0)] = 1;
  ms::write_solid_file(dir / "solid.h5", m, "test", "{\"a\": 1}");
  const ms::SolidMask r = ms::read_solid_file(dir / "solid.h5");
  EXPECT_EQ(r.dims, m.dims);
  EXPECT_EQ(r.voxel, m.voxel);
  EXPECT_EQ(r.origin, m.origin);
  EXPECT_EQ(r.nm_per_rc, m.nm_per_rc);
  EXPECT_EQ(r.solid, m.solid);
  EXPECT_NEAR(r.porosity(), 28.0 / 30.0, 1e-15);
  for (const auto& e : std::filesystem::directory_iterator(dir))  // .NAME.PID.partial
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  try {
    ms::read_solid_file(dir / "missing.h5");
    FAIL() << "a missing file was read";
  } catch (const mesorock::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.h5: no such file"), std::string::npos);
  }
  {
    std::FILE* f = std::fopen((dir / "junk.h5").c_str(), "w");
    std::fputs("not hdf5", f);
    std::fclose(f);
  }
  EXPECT_THROW(ms::read_solid_file(dir / "junk.h5"), mesorock::IoError);
  ms::SolidMask bad = m;
  bad.solid.pop_back();
  EXPECT_THROW(ms::write_solid_file(dir / "bad.h5", bad, "test", "{}"), mesorock::ConfigError);
  EXPECT_FALSE(fs::exists(dir / "bad.h5"));
  bad = m;
  bad.voxel[1] = -1;
  EXPECT_THROW(ms::write_solid_file(dir / "bad.h5", bad, "test", "{}"), mesorock::ConfigError);
  fs::remove_all(dir);
}

struct Scenario {
  ms::Model model;
  ms::BoxSpec box;
  ms::ParticleSet particles;
};

class Solid : public OnEveryBackend {};

// No forces (DPD with a = 0, no thermostat): one particle flies at the solid voxels x in [1, 2).
TEST_P(Solid, AParticleThatDriftsIntoTheSolidIsSentBack) {
  for (bool bounce : {true, false}) {
    Scenario s;
    s.model.conservative = ms::ConservativeKind::DPD;
    s.model.thermostat = false;
    s.model.add_type({"fluid", false, {0, 0, 0}});
    s.model.set_pair(0, 0, {0, 0, 0});
    s.box.hi = {4, 4, 4};
    auto mask = std::make_shared<ms::SolidMask>(empty_mask(8, 8, 8, 0.5));
    for (int k = 0; k < 8; ++k)
      for (int j = 0; j < 8; ++j)
        for (int i = 2; i < 4; ++i) mask->solid[mask->index(i, j, k)] = 1;
    s.model.solid.mask = mask;
    s.model.solid.bounce = bounce;
    s.model.solid.stop_count = 10;
    s.particles.add(0.95, 2.1, 2.2, 10.0, 0.5, 0, 0, 7);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    sim->run(1);
    const ms::ParticleSet p = sim->particles();
    if (bounce) {
      EXPECT_NEAR(p.vx[0], -10.0, 1e-12);
      EXPECT_NEAR(p.vy[0], -0.5, 1e-12);
      EXPECT_NEAR(p.x[0], 0.85, 1e-12);
      EXPECT_NEAR(p.y[0], 2.095, 1e-12);
      EXPECT_EQ(sim->solid_intrusion().inside, 0u);
    } else {
      EXPECT_NEAR(p.x[0], 1.05, 1e-12);
      const ms::SolidIntrusion in = sim->solid_intrusion();
      ASSERT_TRUE(in.available);
      EXPECT_EQ(in.inside, 1u);
      EXPECT_NEAR(in.max_depth, 0.05, 1e-12);
      EXPECT_EQ(in.deepest_id, 7);
    }
  }
}

// A DPD fluid (density 3) pushed by a body force onto a hollow grain, the case that let real rock
// leak: a cube of 2 rc whose wall particles (density 8, the wall model on) fill only its outer
// voxel layer (0.5 rc), the rest empty, as rockprep leaves grain interiors. At the cube's edges
// and corners phi stays below 1/2, fluid gets into the shell, and deeper in the shell the
// corrector's normal points into the grain. Without the bounce the fluid ends up inside the grain;
// with it none does, at any check.
Scenario fluid_around_a_hollow_grain(bool bounce) {
  Scenario s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.seed = 4;
  const int fluid = s.model.add_type({"fluid", false, {0, 0, -3.0}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {25, 0, 4.5});
  s.model.set_pair(fluid, wall, {5, 0, 4.5});
  s.model.set_pair(wall, wall, {25, 0, 4.5});
  s.model.wall_model.enabled = true;
  s.box.hi = {6, 6, 6};
  auto mask = std::make_shared<ms::SolidMask>(empty_mask(12, 12, 12, 0.5));
  for (int k = 4; k < 8; ++k)
    for (int j = 4; j < 8; ++j)
      for (int i = 4; i < 8; ++i) mask->solid[mask->index(i, j, k)] = 1;  // [2, 4)^3
  s.model.solid.mask = mask;
  s.model.solid.bounce = bounce;
  s.model.solid.stop_count = 1000000;
  s.model.solid.stop_depth = 4;  // let the leak happen; counting it is the point here
  std::int64_t next = 0;
  ms::ParticleSet shell;
  ms::fill_lattice(shell, wall, {2, 2, 2}, {4, 4, 4}, 8, next);
  for (size_t i = 0; i < shell.size(); ++i) {
    const bool interior = shell.x[i] > 2.5 && shell.x[i] < 3.5 && shell.y[i] > 2.5 &&
                          shell.y[i] < 3.5 && shell.z[i] > 2.5 && shell.z[i] < 3.5;
    if (!interior) s.particles.add(shell.x[i], shell.y[i], shell.z[i], 0, 0, 0, wall, shell.id[i]);
  }
  ms::ParticleSet all;
  ms::fill_random(all, fluid, {0, 0, 0}, {6, 6, 6}, 6 * 6 * 6 * 3, 4, next);
  for (size_t i = 0; i < all.size(); ++i)
    if (!mask->is_solid(static_cast<int>(all.x[i] / 0.5), static_cast<int>(all.y[i] / 0.5),
                        static_cast<int>(all.z[i] / 0.5)))
      s.particles.add(all.x[i], all.y[i], all.z[i], 0, 0, 0, fluid, all.id[i]);
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 4);
  return s;
}

TEST_P(Solid, FluidPressedOntoAHollowGrainLeaksWithoutTheBounceAndNotWithIt) {
  std::uint64_t most[2] = {0, 0};
  for (int bounce : {0, 1}) {
    Scenario s = fluid_around_a_hollow_grain(bounce == 1);
    ms::SimulationOptions o = options();
    o.threads = 1;  // a small system: one thread (ARCHITECTURE.md, OpenMP on a busy machine)
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    for (int check = 0; check < 8; ++check) {
      sim->run(100);
      const ms::SolidIntrusion in = sim->solid_intrusion();
      most[bounce] = std::max(most[bounce], in.inside);
    }
  }
  std::printf(
      "fluid particles inside the grain at the worst check: %llu without the bounce, "
      "%llu with\n",
      static_cast<unsigned long long>(most[0]), static_cast<unsigned long long>(most[1]));
  EXPECT_GT(most[0], 5u) << "the set-up must press fluid into the unprotected grain";
  EXPECT_EQ(most[1], 0u);
}

// A thermo row's sums come from the engine where the particles are (on the GPU, no download):
// temperature, momentum, kinetic stress and the leak invariant against the same sums over the
// particles on the host, with fluid inside the grain (no bounce) and frozen walls to skip.
TEST_P(Solid, ThermoRowSumsAreThoseOfTheParticles) {
  Scenario s = fluid_around_a_hollow_grain(false);
  ms::SimulationOptions o = options();
  o.threads = 1;
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
  sim->run(300);
  const ms::ParticleSet p = sim->particles();
  double v2 = 0, count = 0, mom[3] = {0, 0, 0}, kin[6] = {0, 0, 0, 0, 0, 0};
  std::uint64_t inside = 0;
  double deepest = -1;
  std::int64_t deepest_id = -1;
  for (size_t i = 0; i < p.size(); ++i) {
    if (p.type[i] != 0) continue;  // the frozen wall
    const double u[3] = {p.vx[i], p.vy[i], p.vz[i]};
    v2 += u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    count += 1;
    for (int a = 0; a < 3; ++a) mom[a] += u[a];
    const double k[6] = {u[0] * u[0], u[1] * u[1], u[2] * u[2],
                         u[0] * u[1], u[0] * u[2], u[1] * u[2]};
    for (int c = 0; c < 6; ++c) kin[c] += k[c];
    const double x[3] = {p.x[i], p.y[i], p.z[i]};
    double depth = 1e300;  // the grain is the cube [2, 4)^3: depth = distance to its nearest face
    for (double c : x) depth = std::min({depth, c - 2, 4 - c});
    if (depth <= 0) continue;
    ++inside;
    if (depth > deepest + 1e-9 || (std::abs(depth - deepest) <= 1e-9 && p.id[i] < deepest_id)) {
      deepest = depth;
      deepest_id = p.id[i];
    }
  }
  ASSERT_GT(inside, 0u) << "the set-up must press fluid into the grain";
  EXPECT_NEAR(sim->kinetic_temperature(), v2 / (3 * count), 1e-9);
  const auto m = sim->momentum();
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(m[a], mom[a], 1e-9 * count);
  const ms::StressSample st = sim->stress();
  for (int c = 0; c < 6; ++c) EXPECT_NEAR(st.kinetic[c] * 216, kin[c], 1e-9 * count) << c;
  const ms::SolidIntrusion in = sim->solid_intrusion();
  ASSERT_TRUE(in.available);
  EXPECT_EQ(in.inside, inside);
  EXPECT_NEAR(in.max_depth, deepest, 1e-5);
  EXPECT_EQ(in.deepest_id, deepest_id);
}

TEST_P(Solid, TheWatchdogStopsAParticleDeepInTheSolid) {
  Scenario s = fluid_around_a_hollow_grain(false);
  s.model.solid.stop_depth = 0.05;
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  try {
    sim->run(1000);
    FAIL() << "no particle got 0.05 rc deep into the grain";
  } catch (const mesorock::NumericalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("leaked into the solid"), std::string::npos) << what;
    EXPECT_NE(what.find("particle "), std::string::npos) << what;
  }
}

// One turn per step (StepView::left_to_grid). A fluid particle in a pocket of one pore voxel,
// [1.5, 2)^3, walled in by wall particles on every side but +x, where the solid voxel next to it
// is empty (a grain interior), pushed towards that voxel by a body force of 40. phi's normal
// points to +x, away from the walls, while the solid the particle hits is at +x; phi_c = 0.2 so
// that phi exceeds it next to that face (the lattice is too sparse there for 1/2). No
// conservative force and a thermostat of gamma = 0 (the wall model needs one): nothing damps it.
// When the bounce and the corrector both turned it in one step, the second turn undid the first
// and the push added dt g = 0.4 to its speed at every step at the face: 26 after 300 steps (the
// Berea runaway, docs/walls.md). With the bounce's turns alone the corrector also turned it on
// some steps and not on others (it was inside the wall): 7.3. Now the corrector leaves a particle
// that started the step inside the wall to the grid: 6.9, which is the bounce-back's own gain
// under a steady push (it puts the particle back a step's move from where it started, not where
// a mirror would); a thermostat's dissipation bounds it.
TEST_P(Solid, AParticleInAPocketItCannotLeaveIsTurnedOncePerStep) {
  Scenario s;
  s.model.conservative = ms::ConservativeKind::DPD;
  s.model.thermostat = true;
  const int fluid = s.model.add_type({"fluid", false, {40.0, 0, 0}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {0, 0, 0});
  s.model.set_pair(fluid, wall, {0, 0, 0});
  s.model.set_pair(wall, wall, {0, 0, 0});
  s.model.wall_model.enabled = true;
  s.model.wall_model.penetration_threshold = 0.2;
  s.box.hi = {4, 4, 4};
  auto mask = std::make_shared<ms::SolidMask>(empty_mask(8, 8, 8, 0.5));
  for (auto& b : mask->solid) b = 1;
  mask->solid[mask->index(3, 3, 3)] = 0;
  s.model.solid.mask = mask;
  std::int64_t next = 0;
  ms::ParticleSet walls;
  ms::fill_lattice(walls, wall, {0, 0, 0}, {4, 4, 4}, 12, next);
  for (size_t i = 0; i < walls.size(); ++i) {
    const bool hollow = walls.x[i] >= 2.0 && walls.x[i] < 2.5;
    if (!hollow &&
        mask->is_solid(static_cast<int>(walls.x[i] / 0.5), static_cast<int>(walls.y[i] / 0.5),
                       static_cast<int>(walls.z[i] / 0.5)))
      s.particles.add(walls.x[i], walls.y[i], walls.z[i], 0, 0, 0, wall, walls.id[i]);
  }
  s.particles.add(1.9, 1.74, 1.77, 1.0, 0.1, -0.05, fluid, next);
  auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
  double fastest = 0;
  for (int k = 0; k < 60; ++k) {
    sim->run(5);
    const ms::ParticleSet p = sim->particles();
    const size_t i = p.size() - 1;
    ASSERT_EQ(p.type[i], fluid);
    fastest =
        std::max(fastest, std::sqrt(p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i]));
  }
  std::printf("fastest in the pocket: %.3g, corrections %llu\n", fastest,
              static_cast<unsigned long long>(sim->wall_corrections()));
  EXPECT_LT(sim->wall_corrections(), 5u) << "inside the wall, the corrector leaves it to the grid";
  EXPECT_EQ(sim->solid_intrusion().inside, 0u);
  EXPECT_LT(fastest, 12.0);  // 6.9 left to the grid, 26 turned twice in a step
}

// A wall 3 rc thick filling its solid voxels (z in [0, 3)), under an mDPD liquid with the wall
// model and the bounce (the pore above it, periodic in z). Random wall positions: every depth
// occurs, so a margin that left out too much would show.
Scenario wall_under_liquid() {
  Scenario s;
  s.model.conservative = ms::ConservativeKind::MDPD;
  s.model.seed = 12;
  const int fluid = s.model.add_type({"fluid", false, {0.5, 0, -0.3}});
  const int wall = s.model.add_type({"wall", true, {0, 0, 0}});
  s.model.set_pair(fluid, fluid, {-40, 25, 4.5});
  s.model.set_pair(fluid, wall, {-30, 25, 4.5});
  s.model.set_pair(wall, wall, {-40, 25, 4.5});
  s.model.wall_model.enabled = true;
  s.box.hi = {6, 6, 8};
  auto mask = std::make_shared<ms::SolidMask>(empty_mask(12, 12, 16, 0.5));
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i) mask->solid[mask->index(i, j, k)] = 1;
  s.model.solid.mask = mask;
  std::int64_t next = 0;
  ms::fill_random(s.particles, wall, {0, 0, 0}, {6, 6, 3}, 702, 13, next);
  ms::fill_random(s.particles, fluid, {0, 0, 3.05}, {6, 6, 7.95}, 1146, 12, next);  // rho 6.5
  ms::assign_maxwell_velocities(s.particles, s.model, 1.0, 12);
  return s;
}

// The buried part (SimulationOptions::buried_part): the wall's particles farther than rc from the
// pore leave the steps; rho, phi and the forces are those of the run that keeps them up to the
// order of the static sums, and so are the corrections and trajectories over 30 steps.
TEST_P(Solid, BuriedWallParticlesChangeOnlyTheOrderOfSums) {
  const Scenario s = wall_under_liquid();
  const int wall = 1;
  ms::SimulationOptions on = options(), off = options();
  off.buried_part = false;
  on.threads = off.threads = 2;
  auto a = ms::make_simulation(s.model, s.box, s.particles, 0.01, on);
  auto b = ms::make_simulation(s.model, s.box, s.particles, 0.01, off);
  EXPECT_EQ(b->buried_particles(), 0u);
  // Farther than rc from the pore above (z >= 3) and from its periodic image below (z < 0).
  std::uint64_t deep = 0;
  for (size_t i = 0; i < s.particles.size(); ++i)
    deep += s.particles.type[i] == wall && s.particles.z[i] > 1.001 && s.particles.z[i] < 1.999;
  EXPECT_GT(deep, 100u);
  EXPECT_EQ(a->buried_particles(), deep);
  const auto ra = a->densities(), rb = b->densities();
  const auto pa = a->boundary_volume_fractions(), pb = b->boundary_volume_fractions();
  const auto fa = a->forces(), fb = b->forces();
  for (size_t i = 0; i < ra.size(); ++i) {
    ASSERT_NEAR(ra[i], rb[i], 1e-12 * (1 + ra[i])) << "particle " << i;
    ASSERT_NEAR(pa[i], pb[i], 1e-12) << "particle " << i;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(fa[c][i], fb[c][i], 1e-9) << "particle " << i;
  }
  a->run(30);
  b->run(30);
  EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
  const ms::ParticleSet qa = a->particles(), qb = b->particles();
  for (size_t i = 0; i < qa.size(); ++i) {
    ASSERT_EQ(qa.id[i], qb.id[i]);
    ASSERT_NEAR(qa.z[i], qb.z[i], 1e-7) << "particle " << i;
    ASSERT_NEAR(qa.vx[i], qb.vx[i], 1e-5) << "particle " << i;
  }
  EXPECT_EQ(a->solid_intrusion().inside, 0u);
}

// The frozen density list (SimulationOptions::frozen_density_list; the GPU's, the CPU ignores
// it): the wall's particles within rc but farther than rd from the pore (z in [2, 2.25) and
// (0.75, 1]) keep their static sums instead of summing the liquid every step. Nothing changes,
// bit for bit: rho, phi and the forces of every particle, then 30 steps (graphs included).
TEST_P(Solid, FrozenDensityListChangesNoBit) {
  const Scenario s = wall_under_liquid();
  std::uint64_t quiet = 0;  // what the list leaves out
  for (size_t i = 0; i < s.particles.size(); ++i) {
    const double z = s.particles.z[i];
    quiet += s.particles.type[i] == 1 && ((z >= 2.0 && z < 2.249) || (z > 0.751 && z <= 1.0));
  }
  EXPECT_GT(quiet, 100u);
  ms::SimulationOptions on = options(), off = options();
  off.frozen_density_list = false;
  auto a = ms::make_simulation(s.model, s.box, s.particles, 0.01, on);
  auto b = ms::make_simulation(s.model, s.box, s.particles, 0.01, off);
  auto same = [&](const char* when) {
    EXPECT_EQ(a->densities(), b->densities()) << when;
    EXPECT_EQ(a->boundary_volume_fractions(), b->boundary_volume_fractions()) << when;
    EXPECT_EQ(a->forces(), b->forces()) << when;
  };
  same("after the set-up");
  a->run(30);
  b->run(30);
  same("after 30 steps");
  EXPECT_EQ(a->wall_corrections(), b->wall_corrections());
  const ms::ParticleSet qa = a->particles(), qb = b->particles();
  EXPECT_EQ(qa.id, qb.id);
  EXPECT_EQ(qa.x, qb.x);
  EXPECT_EQ(qa.z, qb.z);
  EXPECT_EQ(qa.vy, qb.vy);
  EXPECT_EQ(a->solid_intrusion().inside, 0u);
}

TEST_P(Solid, ParticlesThatStartInTheSolidAreRefused) {
  Scenario s = fluid_around_a_hollow_grain(true);
  s.particles.add(3.0, 3.0, 3.0, 0, 0, 0, 0, 999999);
  try {
    ms::make_simulation(s.model, s.box, s.particles, 0.01, options());
    FAIL() << "a fluid particle inside the grain was accepted";
  } catch (const mesorock::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("particle 999999"), std::string::npos) << e.what();
  }
}

MESOROCK_ON_EVERY_BACKEND(Solid);

// The bounce changes nothing about the thread-count independence of the CPU backend.
TEST(SolidThreads, SameTrajectoryOnOneAndTwoThreads) {
  ms::ParticleSet out[2];
  for (int t : {1, 2}) {
    Scenario s = fluid_around_a_hollow_grain(true);
    ms::SimulationOptions o;
    o.threads = t;
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, o);
    sim->run(100);
    out[t - 1] = sim->particles();
  }
  EXPECT_EQ(out[0].x, out[1].x);
  EXPECT_EQ(out[0].z, out[1].z);
  EXPECT_EQ(out[0].vz, out[1].vz);
}

}  // namespace
