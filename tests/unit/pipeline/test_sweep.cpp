// Permeability sweeps: the fits against exact and synthetic noisy data (their error bars must be
// right, or the darcy-linearity verdict means nothing), the steady-state rule on a flow that
// never settles, and `rockflow sweep` end to end at a tiny size (outputs, units, the viscosity
// cache reused by a second sweep).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "mesorock/errors.h"
#include "pipeline/flow/darcy_fit.h"
#include "pipeline/flow/sweep.h"
#include "pipeline/flow/systems.h"
#include "pipeline/scene.h"
#include "sim/particle_io.h"
#include "support/test_support.h"
#include "unit/pipeline/tiny_slit.h"

namespace fs = std::filesystem;
namespace mp = mesorock::pipeline;
using mesorock::test::CommandResult;
using mesorock::test::TempDir;

namespace {

TEST(SweepFits, ExactDataGiveTheirCoefficients) {
  const std::vector<double> x = {1, 2, 3}, e = {1, 1, 1};
  const auto p = mp::fit_proportional(x, {2, 4, 6}, e);
  EXPECT_DOUBLE_EQ(p.slope, 2);
  EXPECT_NEAR(p.chi2, 0, 1e-20);
  EXPECT_NEAR(p.slope_error, 1 / std::sqrt(14.0), 1e-15);  // 1 / sqrt(sum x^2 / e^2)
  EXPECT_EQ(p.dof, 2);
  const auto l = mp::fit_line(x, {3, 5, 7}, e);
  EXPECT_NEAR(l.intercept, 1, 1e-12);
  EXPECT_NEAR(l.slope, 2, 1e-12);
  // Unit weights: var(a) = sum x^2 / (N sum x^2 - (sum x)^2) = 14 / 6, var(b) = N / 6.
  EXPECT_NEAR(l.intercept_error, std::sqrt(14.0 / 6), 1e-12);
  EXPECT_NEAR(l.slope_error, std::sqrt(3.0 / 6), 1e-12);
  EXPECT_NEAR(l.covariance, -6.0 / 6, 1e-12);
  const auto q = mp::fit_quadratic_through_origin({1, 2, 3, 4}, {2.1, 4.4, 6.9, 9.6}, {1, 1, 1, 1});
  EXPECT_NEAR(q.c1, 2, 1e-12);
  EXPECT_NEAR(q.c2, 0.1, 1e-12);
  EXPECT_NEAR(q.departure(3), 0.15, 1e-12);
  EXPECT_NEAR(mp::chi2_99(1), 6.635, 1e-3);
  EXPECT_NEAR(mp::chi2_99(20), 37.57, 0.1);  // Wilson-Hilferty against the table value
  EXPECT_THROW(mp::fit_line({1}, {1}, {1}), mesorock::ConfigError);
  EXPECT_THROW(mp::fit_line({1, 2}, {1, 2}, {1, 0}), mesorock::ConfigError);
  EXPECT_THROW(mp::fit_proportional({1, 2}, {1}, {1, 1}), mesorock::ConfigError);
}

// 4,000 synthetic sweeps q = s G + noise with known errors: the fitted parameters scatter as
// their error bars say (pulls of unit spread), and |intercept| < 2 errors in about 95% of them
// (the darcy-linearity criterion); a quadratic truth is flagged by the departure and by chi^2.
TEST(SweepFits, ErrorBarsAreRightOnSyntheticData) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal(0.0, 1.0);
  const std::vector<double> G = {0.1, 0.2, 0.3, 0.4};
  const std::vector<double> err = {0.002, 0.003, 0.003, 0.004};
  const double slope = 0.5;
  const int trials = 4000;
  double pull_a = 0, pull_s = 0, pull_c2 = 0;
  int within = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> q;
    for (size_t k = 0; k < G.size(); ++k) q.push_back(slope * G[k] + err[k] * normal(rng));
    const auto line = mp::fit_line(G, q, err);
    const auto prop = mp::fit_proportional(G, q, err);
    const auto quad = mp::fit_quadratic_through_origin(G, q, err);
    pull_a += std::pow(line.intercept / line.intercept_error, 2);
    pull_s += std::pow((prop.slope - slope) / prop.slope_error, 2);
    pull_c2 += std::pow(quad.c2 / quad.c2_error, 2);
    within += std::abs(line.intercept) <= 2 * line.intercept_error;
  }
  EXPECT_NEAR(std::sqrt(pull_a / trials), 1.0, 0.05);
  EXPECT_NEAR(std::sqrt(pull_s / trials), 1.0, 0.05);
  EXPECT_NEAR(std::sqrt(pull_c2 / trials), 1.0, 0.05);
  EXPECT_NEAR(within / double(trials), 0.954, 0.015);
  // A 10% quadratic departure at the largest gradient: detected.
  std::vector<double> q;
  for (double g : G) q.push_back(slope * g * (1 - 0.25 * g));
  const auto quad = mp::fit_quadratic_through_origin(G, q, err);
  EXPECT_NEAR(quad.departure(0.4), -0.1, 1e-9);
  EXPECT_GT(std::abs(quad.departure(0.4)), 2 * quad.departure_error(0.4));
}

// The drift test of the steady state (Student's t_99 on the least-squares trend of the measured
// blocks): a flux still falling by 20% across 10 noisy blocks (the leaking rock's fell by 24%
// across 16) is caught; flat noise passes about 99% of the time, as its level says.
TEST(SweepFits, TheTrendTestCatchesAFallingFluxAndPassesFlatNoise) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  int caught = 0, flagged = 0;
  const int trials = 4000;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> falling, flat;
    for (int k = 0; k < 10; ++k) {
      falling.push_back(5e-3 * (1 - 0.02 * k) + 1e-4 * normal(rng));
      flat.push_back(5e-3 + 1e-4 * normal(rng));
    }
    caught += mp::trend_of(falling, 0, falling.size()).significant();
    flagged += mp::trend_of(flat, 0, flat.size()).significant();
  }
  EXPECT_GT(caught, 0.99 * trials);
  EXPECT_NEAR(flagged / double(trials), 0.01, 0.006);
  EXPECT_FALSE(mp::trend_of({1, 2}, 0, 2).significant());  // too few blocks to judge
  EXPECT_NEAR(mp::t_99(8), 3.355, 1e-9);
}

// A periodic fluid with no walls accelerates under a body force forever: never steady.
TEST(Sweep, AnAcceleratingFlowIsNotSteady) {
  const double L[3] = {3, 3, 3};
  auto s = mp::make_bulk_dpd(25, 4.5, 3.0, L, 5);
  mp::SweepOptions o;
  o.forces = {0.05};
  o.driven_types = 1;
  o.fluid_density = 3;
  o.viscosity = 1;
  o.warmup_steps = 0;
  o.block_steps = 100;
  o.window = 2;
  o.measure_blocks = 2;
  o.max_steps = 1000;
  const auto points = mp::run_sweep({s.model, s.box, s.particles}, o);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_FALSE(points[0].steady);
  EXPECT_EQ(points[0].steps, 1000u);
  EXPECT_EQ(points[0].block_flux.size(), 10u);
  // J = n <v> grows as n g t: the last block's mean velocity is about g t = 0.05 x 9.5.
  EXPECT_NEAR(points[0].block_flux.back() / 3, 0.05 * 9.5, 0.1);
  o.max_steps = 500;  // fewer than warm-up + (2 window + measure) blocks
  EXPECT_THROW(mp::run_sweep({s.model, s.box, s.particles}, o), mesorock::ConfigError);
}

// --side-by-side runs every point at once from the prepared particles: each point must give
// every bit of the same point in an unchained sweep run one point at a time (its own seed, its
// own simulation), and differ from the chained sweep's second point (which starts elsewhere).
TEST(Sweep, SideBySidePointsEqualTheUnchainedPointsOneAtATime) {
  const double L[3] = {4, 4, 4};
  auto s = mp::make_bulk_dpd(25, 4.5, 3.0, L, 5);
  mp::SweepOptions o;
  o.forces = {0.05, 0.02, 0.08};
  o.driven_types = 1;
  o.fluid_density = 3;
  o.viscosity = 1;
  o.warmup_steps = 50;
  o.block_steps = 50;
  o.window = 2;
  o.measure_blocks = 2;
  o.max_steps = 400;
  o.chain = false;
  const auto alone = mp::run_sweep({s.model, s.box, s.particles}, o);
  o.side_by_side = true;
  const auto together = mp::run_sweep({s.model, s.box, s.particles}, o);
  o.side_by_side = false;
  o.chain = true;
  const auto chained = mp::run_sweep({s.model, s.box, s.particles}, o);
  ASSERT_EQ(alone.size(), 3u);
  ASSERT_EQ(together.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(alone[k].force, together[k].force);
    EXPECT_EQ(alone[k].block_flux, together[k].block_flux) << "point " << k;
    EXPECT_EQ(alone[k].temperature, together[k].temperature) << "point " << k;
    EXPECT_EQ(alone[k].flux, together[k].flux) << "point " << k;
  }
  EXPECT_EQ(alone[0].block_flux, chained[0].block_flux);  // the first point starts alike
  EXPECT_NE(alone[1].block_flux, chained[1].block_flux);
}

TEST(SweepCli, TinySweepWritesItsOutputsAndReusesTheCalibration) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << mesorock::test::kTinySlit;
  auto sweep = [&](const std::string& out) {
    return mesorock::test::run_command(
        mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " sweep " +
            mesorock::test::shell_quote(scene.string()) + " --out " +
            mesorock::test::shell_quote((dir / out).string()) +
            " --forces 0.06,0.03 --warmup 200 --block-steps 100 --window 2 --measure-blocks 3 "
            "--max-steps 1500 --calibration tiny --threads 2 --viscosity-cache " +
            mesorock::test::shell_quote((dir / "cache").string()),
        dir.path());
  };
  const CommandResult r = sweep("a");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("permeability (Darcy fit)"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("MPS/s"), std::string::npos) << r.err;  // the progress meter
  const auto j = nlohmann::json::parse(mesorock::test::read_file(dir / "a" / "sweep.json"));
  EXPECT_EQ(j.at("viscosity").at("source"), "calibration");
  const double eta = j.at("viscosity").at("value").get<double>();
  EXPECT_GT(eta, 3);  // the A = -40 liquid: about 7 (tiny calibration: within a factor)
  EXPECT_LT(eta, 12);
  EXPECT_EQ(j.at("flow_axis"), "x");
  EXPECT_EQ(j.at("fluid_density").get<double>(), 7.0);
  EXPECT_EQ(j.at("steady_state").at("warmup").at("source"), "given");
  EXPECT_EQ(j.at("steady_state").at("warmup_steps").get<int>(), 200);
  ASSERT_EQ(j.at("points").size(), 2u);
  EXPECT_LT(j["points"][0]["force_g"].get<double>(), j["points"][1]["force_g"].get<double>());
  for (const auto& p : j.at("points")) {
    EXPECT_GT(p.at("darcy_velocity_q").get<double>(), 0);
    // Definitions: G = n g, q = J / n, k = mu q / G.
    EXPECT_DOUBLE_EQ(p.at("gradient_G").get<double>(), 7.0 * p.at("force_g").get<double>());
    EXPECT_NEAR(p.at("darcy_velocity_q").get<double>(), p.at("flux_J").get<double>() / 7.0, 1e-15);
    const auto& k = p.at("permeability");
    EXPECT_NEAR(k.at("rc2").get<double>(),
                eta * p.at("darcy_velocity_q").get<double>() / p.at("gradient_G").get<double>(),
                1e-12);
    EXPECT_NEAR(k.at("nm2").get<double>(), k.at("rc2").get<double>() * 0.852 * 0.852, 1e-9);
    // 1 mD = 9.869233e-16 m^2 = 9.869233e2 nm^2.
    EXPECT_NEAR(k.at("mD").get<double>(), k.at("nm2").get<double>() / 986.9233, 1e-9);
  }
  const auto& darcy = j.at("fits").at("darcy").at("permeability");
  EXPECT_GT(darcy.at("rc2").get<double>(), 0);
  EXPECT_TRUE(j.at("fits").contains("line"));
  EXPECT_FALSE(j.at("fits").contains("quadratic"));  // two points only
  const std::string csv = mesorock::test::read_file(dir / "a" / "sweep.csv");
  EXPECT_NE(csv.find("point,force_g,gradient_G"), std::string::npos);
  const std::string png = mesorock::test::read_file(dir / "a" / "sweep.png");
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_TRUE(fs::exists(dir / "a" / "sweep_blocks.csv"));
  const std::string cache_file = j.at("viscosity").at("cache_file").get<std::string>();
  EXPECT_TRUE(fs::exists(cache_file));
  // The points' throughput: the frozen wall counts in `particles`, not in `mobile_particles`
  // (here the one fluid type, water).
  const auto& tp = j.at("throughput");
  const double all = tp.at("particles").get<double>(),
               mobile = tp.at("mobile_particles").get<double>();
  EXPECT_EQ(mobile, j.at("fluid_particles").get<double>());
  EXPECT_LT(mobile, all);
  double steps = 0, seconds = 0;
  for (const auto& p : j.at("points")) steps += p.at("steps").get<double>();
  for (const auto& t : tp.at("point_seconds")) seconds += t.get<double>();
  EXPECT_EQ(tp.at("steps").get<double>(), steps);
  EXPECT_NEAR(tp.at("seconds").get<double>(), seconds, 1e-9 * seconds);
  ASSERT_GT(tp.at("mps").get<double>(), 0.0);
  EXPECT_NEAR(tp.at("mobile_mps").get<double>() / tp.at("mps").get<double>(), mobile / all, 1e-12);

  // The second sweep of the same fluid reads the calibration from the cache.
  const CommandResult again = sweep("b");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto k = nlohmann::json::parse(mesorock::test::read_file(dir / "b" / "sweep.json"));
  EXPECT_EQ(k.at("viscosity").at("source"), "cache");
  EXPECT_EQ(k.at("viscosity").at("value").get<double>(), eta);
  // Same scene and seeds: the same flow rates.
  EXPECT_EQ(k.at("points"), j.at("points"));

  // A damaged cache file (its key intact, its viscosity not a number) is calibrated again and
  // replaced, not read as a json type error.
  auto damaged = nlohmann::json::parse(mesorock::test::read_file(cache_file));
  damaged["viscosity"]["value"] = "seven";
  std::ofstream(cache_file) << damaged.dump();
  const CommandResult third = sweep("c");
  ASSERT_EQ(third.exit_code, 0) << third.err;
  const auto c = nlohmann::json::parse(mesorock::test::read_file(dir / "c" / "sweep.json"));
  EXPECT_EQ(c.at("viscosity").at("source"), "calibration");
  EXPECT_EQ(c.at("viscosity").at("value").get<double>(), eta);
  const auto repaired = nlohmann::json::parse(mesorock::test::read_file(cache_file));
  EXPECT_EQ(repaired.at("viscosity").at("value").get<double>(), eta);
}

// `rockflow sweep SCENE --out DIR/o`, the start of the refusal tests' command lines.
std::string sweep_into_o(const fs::path& scene, const TempDir& dir) {
  return mesorock::test::shell_quote(MESOROCK_ROCKFLOW) + " sweep " +
         mesorock::test::shell_quote(scene.string()) + " --out " +
         mesorock::test::shell_quote((dir / "o").string());
}

// The default warm-up from the median pore (docs/permeability.md, "Choosing the resolution"):
// the resolution study on real rock validated these warm-ups against the LBM (docs/accuracy.md,
// Berea 50^3 crop at 1.2, 1.6 and 2.0 rc per voxel: median pores of 9.09, 12.1 and 15.1 rc;
// mu = 6.111 at n_f = 6.5, dt = 0.01). The rule must give them or up to 15% more.
TEST(SweepWarmup, TheRuleGivesTheResolutionStudysWarmupsOrALittleMore) {
  const double nu = 6.111 / 6.5;
  const std::pair<double, std::uint64_t> study[] = {{9.0859, 2880}, {12.1, 5120}, {15.143, 8000}};
  for (const auto& [d, used] : study) {
    const std::uint64_t steps = mp::viscous_warmup_steps(d, nu, 0.01, 2000);
    EXPECT_GE(steps, used) << "d = " << d;
    EXPECT_LE(static_cast<double>(steps), 1.15 * static_cast<double>(used)) << "d = " << d;
    EXPECT_EQ(steps % 100, 0u);
  }
  // Four times the pore, sixteen times the warm-up (to the rounding); never below the least.
  EXPECT_NEAR(static_cast<double>(mp::viscous_warmup_steps(40, nu, 0.01, 0)),
              16.0 * static_cast<double>(mp::viscous_warmup_steps(10, nu, 0.01, 0)), 1600);
  EXPECT_EQ(mp::viscous_warmup_steps(3.79, nu, 0.01, 2000), 2000u);  // 0.5 rc per voxel
  EXPECT_THROW(mp::viscous_warmup_steps(0, nu, 0.01, 2000), mesorock::ConfigError);
  EXPECT_THROW(mp::viscous_warmup_steps(10, -1, 0.01, 2000), mesorock::ConfigError);
  EXPECT_THROW(mp::viscous_warmup_steps(NAN, nu, 0.01, 2000), mesorock::ConfigError);
}

// rockprep run records its block's pore sizes in the particle file's provenance; the sweep's
// default warm-up comes from them unless --warmup was given.
TEST(SweepWarmup, ComesFromTheSamplesMedianPoreUnlessGiven) {
  TempDir dir;
  auto scene_with = [&](const std::string& name, const std::string& provenance) {
    mesorock::sim::ParticleSet walls;
    walls.add(1.0, 1.0, 0.5, 0, 0, 0, 0, 0);
    mesorock::sim::ParticleFileMeta meta;
    meta.type_names = {"wall"};
    meta.box.hi = {4, 4, 7};
    meta.provenance_json = provenance;
    mesorock::sim::write_particle_file(dir / (name + ".h5"), walls, meta);
    const fs::path toml = dir / (name + ".toml");
    std::ofstream(toml) << mesorock::test::kTinySlit << "[[init]]\nkind = \"file\"\nfile = \""
                        << name << ".h5\"\n";
    return mp::load_scene(toml);
  };
  const mp::Scene recorded = scene_with("recorded", R"({"pore_sizes": {"median_rc": 12.1}})");
  EXPECT_EQ(mp::median_pore_diameter_of(recorded), 12.1);
  mp::SweepCommand c;
  mp::SweepOptions o;
  o.viscosity = 6.111;
  o.fluid_density = 6.5;
  o.dt = 0.01;
  const mp::SweepOptions defaults = o;

  nlohmann::json why = mp::sweep_warmup(recorded, c, o);  // --warmup given
  EXPECT_EQ(why.at("source"), "given");
  EXPECT_EQ(o.warmup_steps, defaults.warmup_steps);

  c.warmup_from_pores = c.max_steps_from_warmup = true;
  why = mp::sweep_warmup(recorded, c, o);
  EXPECT_EQ(o.warmup_steps, mp::viscous_warmup_steps(12.1, 6.111 / 6.5, 0.01, 2000));
  EXPECT_GT(o.warmup_steps, defaults.warmup_steps);
  EXPECT_EQ(o.max_steps, defaults.max_steps + o.warmup_steps - defaults.warmup_steps);
  EXPECT_EQ(why.at("median_pore_diameter_rc").get<double>(), 12.1);
  EXPECT_EQ(why.at("steps").get<std::uint64_t>(), o.warmup_steps);

  o = defaults;  // --max-steps given: kept
  c.max_steps_from_warmup = false;
  mp::sweep_warmup(recorded, c, o);
  EXPECT_EQ(o.max_steps, defaults.max_steps);

  o = defaults;  // no pore sizes recorded (an older rockprep, a hand-made file): the default
  const mp::Scene bare = scene_with("bare", R"({"fluid_density": 6.5})");
  EXPECT_FALSE(mp::median_pore_diameter_of(bare));
  why = mp::sweep_warmup(bare, c, o);
  EXPECT_EQ(o.warmup_steps, defaults.warmup_steps);
  EXPECT_NE(why.at("source").get<std::string>().find("no pore sizes"), std::string::npos);

  const mp::Scene bad = scene_with("bad", R"({"pore_sizes": {"median_rc": -3}})");
  std::string msg = "<none>";
  try {
    mp::median_pore_diameter_of(bad);
  } catch (const mesorock::ConfigError& e) {
    msg = e.what();
  }
  EXPECT_NE(msg.find("bad.h5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("median_rc"), std::string::npos) << msg;
}

TEST(SweepCli, BadInputIsOneLineAndExitTwo) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << mesorock::test::kTinySlit;
  const std::string base = sweep_into_o(scene, dir);
  for (const std::string& args :
       {std::string(" --forces 0.1,abc"), std::string(" --forces 0"),
        std::string(" --forces 0.1 --types nosuch"), std::string(" --forces 0.1 --types wall")}) {
    const CommandResult r = mesorock::test::run_command(base + args, dir.path());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find("rockflow: error:"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "o" / "sweep.json"));
}

// Refused before any step (issue 22): a repeated force used to run every point and fail at the
// fit; an empty list item was dropped silently; a negative count wrapped to 2^64 - 1 and hung.
TEST(SweepCli, BadListsAndNegativeCountsAreRefusedBeforeAnyStep) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << mesorock::test::kTinySlit;
  const std::string base = sweep_into_o(scene, dir) + " --viscosity 7 --threads 1";
  const std::pair<std::string, std::string> cases[] = {
      {" --forces 0.01,0.01", "given twice"},
      {" --forces 0.02,0.01,0.020", "given twice"},
      {" --forces 0.01,,0.02", "empty item"},
      {" --forces 0.01, ", "empty item"},
      {" --forces 0.01 --warmup -1 --block-steps 50 --window 2 --measure-blocks 2"
       " --max-steps 1000",
       "--warmup"},
      {" --forces 0.01 --max-steps 18446744073709551615", "--max-steps"}};
  for (const auto& [args, what] : cases) {
    const CommandResult r = mesorock::test::run_command(base + args, dir.path());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("MPS/s"), std::string::npos) << args << ": it ran: " << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "o" / "sweep.json"));
}

// The slit without its wall: nothing resists the flow, so there is no permeability to report (an
// all-pore sample used to get k = 3.3 rc^2). Refused before any step.
TEST(SweepCli, ASampleWithoutSolidIsRefused) {
  TempDir dir;
  std::string text = mesorock::test::kTinySlit;
  const std::string wall_block =
      "[[init]]\nkind = \"lattice\"\ntype = \"wall\"\ndensity = 8.0\nhi = [4.0, 4.0, 1.5]\n";
  const auto at = text.find(wall_block);
  ASSERT_NE(at, std::string::npos);
  text.erase(at, wall_block.size());
  const fs::path scene = dir / "bulk.toml";
  std::ofstream(scene) << text;
  const CommandResult r = mesorock::test::run_command(
      sweep_into_o(scene, dir) + " --forces 0.01 --viscosity 7 --threads 1", dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("a sample without solid has no permeability"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("bulk.toml"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("MPS/s"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "o" / "sweep.json"));
}

// Issue 58, item 17: --fluid-density 0 was taken as "not given" (NaN was refused), and
// --viscosity-error -1 was accepted and printed as "mu = 7 +- -1". Refused at parse time.
TEST(SweepCli, ZeroDensityOrANegativeErrorIsRefusedBeforeAnyStep) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << mesorock::test::kTinySlit;
  const std::string base = sweep_into_o(scene, dir) + " --forces 0.01 --threads 1";
  for (const auto& [args, what] :
       {std::pair<std::string, std::string>{" --viscosity 7 --fluid-density 0", "--fluid-density"},
        {" --viscosity 7 --viscosity-error -1", "--viscosity-error"},
        {" --viscosity 0", "--viscosity"},
        {" --viscosity 7 --fluid-density nan", "--fluid-density"}}) {
    const CommandResult r = mesorock::test::run_command(base + args, dir.path());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("MPS/s"), std::string::npos) << args << ": it ran: " << r.err;
  }
}

// Issue 58, items 6, 9 and 13: an --out that cannot be made, or a viscosity cache that cannot be
// written, failed the sweep only after all its work; a folder where a JSON file is expected
// (relperm --sweep) was an internal error ("basic_filebuf::underflow"); a FIFO as
// the scene or as relperm --sweep blocked forever. Each is refused at once, exit 2, naming it.
TEST(SweepCli, UnwritableFoldersAndInputsThatAreNoFilesAreRefusedAtOnce) {
  TempDir dir;
  const fs::path scene = dir / "slit.toml";
  std::ofstream(scene) << mesorock::test::kTinySlit;
  std::ofstream(dir / "afile") << "x";
  const std::string rockflow = mesorock::test::shell_quote(MESOROCK_ROCKFLOW);
  const std::string s = mesorock::test::shell_quote(scene.string());
  ASSERT_EQ(mkfifo((dir / "fifo").c_str(), 0644), 0);
  fs::create_directories(dir / "adir");
  const std::pair<std::string, std::string> cases[] = {
      {"sweep " + s + " --forces 0.01 --viscosity 7 --out afile/o", "afile is a file"},
      {"sweep " + s + " --forces 0.01 --calibration tiny --viscosity-cache afile/c --out o1",
       "afile/c"},
      {"sweep fifo --forces 0.01 --viscosity 7 --out o2", "fifo: not a regular file"},
      {"run fifo --out o3", "fifo: not a regular file"},
      {"relperm " + s + " --saturations 0.5 --placement random --sweep adir --out o4",
       "adir: not a regular file"},
      {"relperm " + s + " --saturations 0.5 --placement random --sweep fifo --out o5",
       "fifo: not a regular file"}};
  for (const auto& [args, what] : cases) {
    const auto t0 = std::chrono::steady_clock::now();
    const CommandResult r =
        mesorock::test::run_command("cd " + mesorock::test::shell_quote(dir.path().string()) +
                                        " && timeout 60 " + rockflow + " " + args + " --threads 1",
                                    dir.path());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("internal error"), std::string::npos) << args << ": " << r.err;
    EXPECT_LT(seconds, 10.0) << args << ": refused only after the work";
  }
}

}  // namespace
