// `rockflow relperm`: the drainage radius on grids whose answer is known (slits of two widths,
// a pore across a periodic face), the placement rules (exact counts, seeds, the largest pores
// first), the per-phase fluxes of the sweep machinery (they add up to the total), the command end
// to end on a tiny slit with a solid grid, and the phase connectivity (layers and drops).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "mesorock/errors.h"
#include "pipeline/flow/phase_connectivity.h"
#include "pipeline/flow/phase_placement.h"
#include "pipeline/flow/sweep.h"
#include "pipeline/flow/systems.h"
#include "sim/particle_io.h"
#include "sim/solid_grid.h"
#include "support/test_support.h"
#include "unit/pipeline/tiny_slit.h"

namespace fs = std::filesystem;
namespace mp = mesorock::pipeline;
namespace ms = mesorock::sim;
using mesorock::test::CommandResult;
using mesorock::test::TempDir;

namespace {

// A grid of nx x 4 x 4 unit voxels whose solid is the x columns listed (every y, z).
ms::SolidMask columns(std::int64_t nx, const std::vector<std::int64_t>& solid_x) {
  ms::SolidMask m;
  m.dims = {nx, 4, 4};
  m.solid.assign(static_cast<size_t>(nx * 16), 0);
  for (std::int64_t k = 0; k < 4; ++k)
    for (std::int64_t j = 0; j < 4; ++j)
      for (std::int64_t x : solid_x) m.solid[m.index(x, j, k)] = 1;
  return m;
}

// Two slits along x: 8 pore voxels (1..8) and 4 (10..13) between solid columns 0, 9, 14. The
// distance of a pore voxel is to the nearest solid centre (1 to 4 in the wide slit), and every
// voxel of a slit is covered by a ball of its largest distance: radius 4 in the wide one, 2 in
// the narrow one.
TEST(DrainageMap, SlitsOfTwoWidthsGetTheirHalfWidths) {
  const ms::SolidMask m = columns(15, {0, 9, 14});
  const mp::DrainageMap d = mp::drainage_map(m, {false, true, true});
  for (std::int64_t x = 1; x <= 8; ++x) {
    EXPECT_FLOAT_EQ(d.radius[m.index(x, 2, 1)], 4.0f) << x;
    EXPECT_FLOAT_EQ(d.distance[m.index(x, 2, 1)], float(std::min(x, 9 - x))) << x;
  }
  for (std::int64_t x = 10; x <= 13; ++x) EXPECT_FLOAT_EQ(d.radius[m.index(x, 0, 3)], 2.0f) << x;
  EXPECT_FLOAT_EQ(d.radius[m.index(9, 0, 0)], 0.0f);  // solid
  EXPECT_FLOAT_EQ(d.largest_radius, 4.0f);
}

// Along a periodic x the slit 10..13 and the one across the face (15, 0..2: solid at 3, 9, 14)
// are both 4 wide: the same radius, 2. Without the wrap the face is not a wall and the slit
// across it looks wider (voxel 0 is 3 from the solid at 3).
TEST(DrainageMap, APoreAcrossAPeriodicFaceIsOnePore) {
  const ms::SolidMask m = columns(16, {3, 9, 14});
  const mp::DrainageMap wrapped = mp::drainage_map(m, {true, true, true});
  for (std::int64_t x : {15, 0, 1, 2, 10, 13})
    EXPECT_FLOAT_EQ(wrapped.radius[m.index(x, 1, 1)], 2.0f) << x;
  const mp::DrainageMap open = mp::drainage_map(m, {false, true, true});
  EXPECT_GE(open.radius[m.index(0, 1, 1)], 3.0f);
  EXPECT_THROW(mp::drainage_map(columns(4, {}), {true, true, true}), mesorock::ConfigError);
}

// Particles at every voxel centre of the two-slit grid, all of type 0.
ms::ParticleSet particles_on(const ms::SolidMask& m) {
  ms::ParticleSet p;
  std::int64_t id = 0;
  for (std::int64_t k = 0; k < m.dims[2]; ++k)
    for (std::int64_t j = 0; j < m.dims[1]; ++j)
      for (std::int64_t i = 0; i < m.dims[0]; ++i)
        if (!m.is_solid(i, j, k)) p.add(i + 0.5, j + 0.5, k + 0.5, 0, 0, 0, 0, id++);
  return p;
}

TEST(PlacePhases, DrainageFillsTheWidePoreFirstAndCountsExactly) {
  const ms::SolidMask m = columns(15, {0, 9, 14});
  const mp::DrainageMap d = mp::drainage_map(m, {false, true, true});
  ms::ParticleSet p = particles_on(m);  // 8 x 16 in the wide slit, 4 x 16 in the narrow one
  ASSERT_EQ(p.size(), 192u);
  // S_w = 1/2: 96 non-wetting particles, all in the wide slit and the farthest from its walls
  // (32 per distance: 4, 3 and 2, voxels x = 2..7).
  const mp::PlacementResult r =
      mp::place_phases(p, 0, 1, 0.5, mp::Placement::Drainage, 1, &d, &m, {false, true, true});
  EXPECT_EQ(r.fluid, 192u);
  EXPECT_EQ(r.nonwetting, 96u);
  EXPECT_DOUBLE_EQ(r.saturation, 0.5);
  EXPECT_FLOAT_EQ(static_cast<float>(r.entry_radius), 4.0f);
  for (size_t i = 0; i < p.size(); ++i) {
    const bool centre = p.x[i] > 2 && p.x[i] < 8;
    EXPECT_EQ(p.type[i], centre ? 1 : 0) << p.x[i];
  }
  // S_w = 0.25: 144 non-wetting, the wide slit whole and 16 in the narrow one's centre.
  ms::ParticleSet q = particles_on(m);
  const auto r2 =
      mp::place_phases(q, 0, 1, 0.25, mp::Placement::Drainage, 1, &d, &m, {false, true, true});
  EXPECT_EQ(r2.nonwetting, 144u);
  EXPECT_FLOAT_EQ(static_cast<float>(r2.entry_radius), 2.0f);
  for (size_t i = 0; i < q.size(); ++i)
    if (q.x[i] < 9) EXPECT_EQ(q.type[i], 1) << q.x[i];
  EXPECT_THROW(mp::place_phases(q, 0, 1, 0.5, mp::Placement::Drainage, 1), mesorock::ConfigError);
  EXPECT_THROW(mp::place_phases(q, 0, 1, 1.5, mp::Placement::Random, 1), mesorock::ConfigError);
}

TEST(PlacePhases, RandomPlacementFollowsTheSeedNotTheOrder) {
  const ms::SolidMask m = columns(15, {0, 9, 14});
  ms::ParticleSet a = particles_on(m), b = a, c = a;
  const auto ra = mp::place_phases(a, 0, 1, 0.3, mp::Placement::Random, 11);
  mp::place_phases(b, 0, 1, 0.3, mp::Placement::Random, 11);
  mp::place_phases(c, 0, 1, 0.3, mp::Placement::Random, 12);
  EXPECT_EQ(ra.nonwetting, 134u);  // round(0.7 x 192)
  EXPECT_EQ(a.type, b.type);
  EXPECT_NE(a.type, c.type);
  // Reversed storage order: each particle (by id) gets the same phase.
  ms::ParticleSet r = particles_on(m);
  std::reverse(r.id.begin(), r.id.end());
  std::reverse(r.x.begin(), r.x.end());
  mp::place_phases(r, 0, 1, 0.3, mp::Placement::Random, 11);
  for (size_t i = 0; i < r.size(); ++i) EXPECT_EQ(r.type[i], a.type[r.size() - 1 - i]);
}

// The sweep's per-phase fluxes are sums over disjoint sets of the driven particles: they add up
// to the total flux in every block.
TEST(SweepPhases, PhaseFluxesAddUpToTheTotal) {
  const double L[3] = {4, 4, 4};
  auto s = mp::make_bulk_dpd(25, 4.5, 3.0, L, 5);
  const int second = s.model.add_type({"second", false, {0, 0, 0}});
  for (int t = 0; t < 2; ++t) s.model.set_pair(second, t, s.model.pair(0, 0));
  for (size_t i = 0; i < s.particles.size(); i += 3) s.particles.type[i] = second;
  mp::SweepOptions o;
  o.driven_types = 1u | (1u << second);
  o.phases = {1u, 1u << second};
  o.fluid_density = 3;
  o.viscosity = 1;
  o.warmup_steps = 0;
  o.block_steps = 50;
  o.window = 2;
  o.measure_blocks = 2;
  o.max_steps = 400;
  // A force large enough that the phases' shares of the momentum stand out of the thermal noise.
  const mp::SweepPoint p =
      mp::run_steady_point({s.model, s.box, s.particles}, o, 1.0, 3, "test", s.particles, o.sim);
  ASSERT_EQ(p.phases.size(), 2u);
  ASSERT_EQ(p.phases[0].block_flux.size(), p.block_flux.size());
  ASSERT_GE(p.block_flux.size(), 6u);
  for (size_t k = 0; k < p.block_flux.size(); ++k)
    EXPECT_NEAR(p.phases[0].block_flux[k] + p.phases[1].block_flux[k], p.block_flux[k],
                1e-12 * std::abs(p.block_flux[k]));
  // Both accelerate (no walls): the first phase holds two thirds of the particles.
  EXPECT_NEAR(p.phases[0].block_flux.back() / p.block_flux.back(), 2.0 / 3, 0.03);
  o.phases = {1u << 5};  // not a driven type
  EXPECT_THROW(
      mp::run_steady_point({s.model, s.box, s.particles}, o, 0.05, 3, "test", s.particles, o.sim),
      mesorock::ConfigError);
}

// The tiny slit (5.5 rc of water over a frozen wall slab) with a solid grid over the slab: the
// drainage placement puts the non-wetting liquid in the middle of the slit.
const std::string kSlit = std::string(mesorock::test::kTinySlit) + "[solid]\nfile = \"solid.h5\"\n";

TEST(RelpermCli, TinySlitWritesItsCurvesAndStates) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << kSlit;
  ms::SolidMask m;  // 0.5 rc voxels, solid below z = 1 (inside the wall slab)
  m.dims = {8, 8, 14};
  m.voxel = {0.5, 0.5, 0.5};
  m.solid.assign(static_cast<size_t>(m.voxels()), 0);
  for (std::int64_t k = 0; k < 2; ++k)
    for (std::int64_t j = 0; j < 8; ++j)
      for (std::int64_t i = 0; i < 8; ++i) m.solid[m.index(i, j, k)] = 1;
  ms::write_solid_file(dir / "solid.h5", m, "test", "{}");
  const std::string common =
      " --warmup 100 --block-steps 50 --window 2 --measure-blocks 2 "
      "--max-steps 600 --threads 2 --saturations 0.4,0.7";
  const CommandResult r = mesorock::test::run_command(
      mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " relperm " +
          mesorock::test::shell_quote(scene.string()) + " --out " +
          mesorock::test::shell_quote((dir / "out").string()) + " --viscosity 7" + common,
      dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("relative permeability (drainage placement"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(mesorock::test::read_file(dir / "out" / "relperm.json"));
  EXPECT_EQ(j.at("placement"), "drainage");
  EXPECT_EQ(j.at("steady_state").at("warmup").at("source"), "given");
  EXPECT_EQ(j.at("steady_state").at("warmup_steps").get<int>(), 100);
  EXPECT_EQ(j.at("phases").at("A_WN").get<double>(), -30.0);
  EXPECT_EQ(j.at("phases").at("A_SN").get<double>(), -40.0);  // neutral by default
  const auto& runs = j.at("runs");
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].at("saturation").get<double>(), 1.0);
  EXPECT_EQ(runs[0].at("kr_W").at("value").get<double>(), 1.0);
  const double fluid = runs[1].at("fluid_particles").get<double>();
  for (int k = 1; k < 3; ++k) {
    const auto& run = runs[k];
    const double want = k == 1 ? 0.4 : 0.7;
    EXPECT_NEAR(run.at("saturation").get<double>(), want, 0.5 / fluid);
    EXPECT_NEAR(run.at("kr_sum").at("value").get<double>(),
                run.at("kr_W").at("value").get<double>() + run.at("kr_N").at("value").get<double>(),
                1e-9);
    // k in rc^2 with the given viscosity: mu J / (n^2 g).
    EXPECT_NEAR(run.at("k_W").at("rc2").get<double>(),
                7 * run.at("flux_W").at("value").get<double>() / (49 * 0.05), 1e-12);
    EXPECT_TRUE(run.contains("solid_invariant"));
  }
  for (const char* f : {"relperm.csv", "relperm_blocks.csv", "relperm.png", "states/S_1.h5",
                        "states/S_1.xmf", "states/S_0.4.h5"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  // The non-wetting liquid starts in the middle of the pore voxels (z = 1 to 7 across the
  // periodic face: the middle is z = 4) and stays there: its particles in the saved state at
  // S_w = 0.4 are read back through the file's type names. Spread evenly over the fluid (z = 1.5
  // to 7) the mean |z - 4| would be 1.39.
  ms::ParticleFileMeta meta;
  const ms::ParticleSet state = ms::read_particle_file(dir / "out" / "states" / "S_0.4.h5", &meta);
  ASSERT_EQ(meta.type_names.size(), 3u);
  EXPECT_EQ(meta.type_names[2], "nonwetting");
  double z_n = 0, n = 0;
  for (size_t i = 0; i < state.size(); ++i)
    if (state.type[i] == 2) z_n += std::abs(state.z[i] - 4.0), ++n;
  ASSERT_GT(n, 0);
  EXPECT_LT(z_n / n, 1.1);  // a layer of 0.6 x 5.5 rc about the middle: mean |dz| about 0.8
  // Side by side (every run at once, --no-states): every run gives the same bits.
  const CommandResult together =
      mesorock::test::run_command(mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " relperm " +
                                      mesorock::test::shell_quote(scene.string()) + " --out " +
                                      mesorock::test::shell_quote((dir / "together").string()) +
                                      " --viscosity 7 --side-by-side --no-states" + common,
                                  dir.path());
  ASSERT_EQ(together.exit_code, 0) << together.err;
  const auto t =
      nlohmann::json::parse(mesorock::test::read_file(dir / "together" / "relperm.json"));
  for (size_t k = 0; k < 3; ++k)
    for (const char* q : {"flux_W", "flux_N", "flux_total"})
      EXPECT_EQ(t["runs"][k][q], runs[k][q]) << k << " " << q;
  EXPECT_FALSE(fs::exists(dir / "together" / "states"));
  // Bad input, each refused with one line naming the problem before any step and any output:
  // a saturation of 1, a sweep summary that is missing or is not one, a cross repulsion that
  // would mix the liquids, too few steps for the steady test.
  const std::string base = mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " relperm " +
                           mesorock::test::shell_quote(scene.string()) + " --out " +
                           mesorock::test::shell_quote((dir / "bad").string()) + " ";
  std::ofstream(dir / "not_a_sweep.json") << "{\"points\": []}";
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"--saturations 0.5 --sweep " + (dir / "none.json").string(), "none.json: cannot open"},
      {"--saturations 0.5 --sweep " + (dir / "not_a_sweep.json").string(),
       "not a rockflow sweep summary"},
      {"--saturations 0.5 --cross-A -50", "less attractive than the fluid's own"},
      {"--saturations 0.5 --max-steps 10", "max steps 10"},
      {"--saturations 0.5 --placement sideways", "placement"}};
  for (const auto& [args, message] : refused) {
    const CommandResult e = mesorock::test::run_command(base + args, dir.path());
    EXPECT_NE(e.exit_code, 0) << args;
    EXPECT_NE(e.err.find(message), std::string::npos) << args << ": " << e.err;
    EXPECT_FALSE(fs::exists(dir / "bad")) << args;
    EXPECT_EQ(e.err.find("particle-steps"), std::string::npos) << args << ": a step ran";
  }
  // A saturation of 1.
  const CommandResult bad = mesorock::test::run_command(
      mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " relperm " +
          mesorock::test::shell_quote(scene.string()) + " --out " +
          mesorock::test::shell_quote((dir / "bad").string()) + " --saturations 0.5,1",
      dir.path());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("strictly between 0 and 1"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

}  // namespace

namespace {

// Particles on a lattice of 0.5 rc in a box L[0] x L[1] x L[2], of type 1 where `second` says,
// else of type 0.
template <class Second>
ms::ParticleSet lattice(const std::array<double, 3>& L, Second second) {
  ms::ParticleSet p;
  std::int64_t id = 0;
  for (double z = 0.25; z < L[2]; z += 0.5)
    for (double y = 0.25; y < L[1]; y += 0.5)
      for (double x = 0.25; x < L[0]; x += 0.5)
        p.add(x, y, z, 0, 0, 0, second(x, y, z) ? 1 : 0, id++);
  return p;
}

// A layer of the second phase (y in [1.5, 2.5)) spans the periodic box along x and z, not along
// y; the first phase around it spans along x but not along y either (a loop around y would cross
// the layer). A sphere spans nothing. Along a bounded axis, spanning is touching both faces.
TEST(PhaseConnectivity, LayersSpanAndDropsDoNot) {
  ms::BoxSpec box;
  box.hi = {6, 4, 4};
  const auto layer =
      lattice({6, 4, 4}, [](double, double y, double) { return y > 1.5 && y < 2.5; });
  const mp::PhaseConnectivity nx = mp::phase_connectivity(layer, 1, box, 0);
  EXPECT_TRUE(nx.spans);
  EXPECT_EQ(nx.clusters, 1u);
  EXPECT_DOUBLE_EQ(nx.spanning_fraction, 1.0);
  EXPECT_EQ(nx.particles, 12u * 2 * 8);
  EXPECT_TRUE(mp::phase_connectivity(layer, 1, box, 2).spans);
  EXPECT_FALSE(mp::phase_connectivity(layer, 1, box, 1).spans);
  EXPECT_TRUE(mp::phase_connectivity(layer, 0, box, 0).spans);
  EXPECT_FALSE(mp::phase_connectivity(layer, 0, box, 1).spans);
  // A drop of radius 1.2 in the middle: one cluster, spanning nothing; its surroundings span.
  const auto drop = lattice({6, 4, 4}, [](double x, double y, double z) {
    return (x - 3) * (x - 3) + (y - 2) * (y - 2) + (z - 2) * (z - 2) < 1.44;
  });
  for (int a = 0; a < 3; ++a) {
    const mp::PhaseConnectivity d = mp::phase_connectivity(drop, 1, box, a);
    EXPECT_FALSE(d.spans) << a;
    EXPECT_EQ(d.clusters, 1u);
    EXPECT_DOUBLE_EQ(d.spanning_fraction, 0.0);
    EXPECT_TRUE(mp::phase_connectivity(drop, 0, box, a).spans) << a;
  }
  // Two drops across the periodic x face (x = 0) are one drop; a gap of 1 rc keeps two layers
  // apart (no bond at 0.7 rc).
  const auto split = lattice({6, 4, 4}, [](double x, double, double) { return x < 1 || x > 5; });
  const mp::PhaseConnectivity s = mp::phase_connectivity(split, 1, box, 0);
  EXPECT_EQ(s.clusters, 1u);
  EXPECT_FALSE(s.spans);  // x in [5, 7) unwrapped: not around the box
  EXPECT_TRUE(mp::phase_connectivity(split, 1, box, 1).spans);
  // Bounded along x: the layer touches both x faces.
  box.periodic = {false, true, true};
  EXPECT_TRUE(mp::phase_connectivity(layer, 1, box, 0).spans);
  EXPECT_FALSE(mp::phase_connectivity(split, 1, box, 0).spans);
}

}  // namespace
