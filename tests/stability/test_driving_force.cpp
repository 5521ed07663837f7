// Very high driving forces. A uniform body force on a periodic fluid meets no resistance (the pair
// forces cancel exactly, F_ij = -F_ji), so the total momentum grows by N g dt per step exactly;
// with g = 1000 the fluid passes the runaway limit (1 rc per step: 100 at dt = 0.01) at step 10,
// where the run must stop with a diagnostic. A strong force through a one-voxel throat is in
// test_throat.cpp.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "high_force_bulk.toml";

TEST(DrivingForce, UniformForceAddsExactlyNgDtOfMomentumPerStep) {
  for (const auto precision : {ms::Precision::Double, ms::Precision::Single}) {
    SceneRun r = load_scene_run(kScene, {{"@G@", "0.5"}});
    r.scene.model.precision = precision;
    r.sim = ms::make_simulation(r.scene.model, r.scene.box, r.initial, 0.01, cpu_options());
    const double n = static_cast<double>(r.sim->size());
    double worst = 0;
    run_stages(r, 20, [&](size_t) {
      const double expected = n * 0.5 * 0.01 * static_cast<double>(r.sim->step());
      worst = std::max(worst, std::abs(r.sim->momentum()[0] - expected) / expected);
    });
    EXPECT_EQ(r.failure, "");
    report(std::string("momentum vs N g t, worst relative error, ") + ms::to_string(precision),
           worst);
    EXPECT_LT(worst, precision == ms::Precision::Double ? 1e-10 : 1e-4);
  }
}

TEST(DrivingForce, HugeForceStopsAtTheStepThatPassesTheRunawayLimit) {
  // g dt per step against a limit of 100: g = 1000 passes it at step 10, g = 1e6 at step 1; in
  // single precision too.
  for (const auto [g, step] : {std::pair{"1000.0", 10}, std::pair{"1.0e6", 1}})
    for (const auto precision : {ms::Precision::Double, ms::Precision::Single}) {
      SceneRun r = load_scene_run(kScene, {{"@G@", g}});
      r.scene.model.precision = precision;
      r.sim = ms::make_simulation(r.scene.model, r.scene.box, r.initial, 0.01, cpu_options());
      run_stages(r, 20);
      EXPECT_TRUE(is_watchdog_message(r.failure)) << r.failure;
      EXPECT_EQ(r.failure.rfind("step " + std::to_string(step) + ": particle ", 0), 0u)
          << "g = " << g << ": " << r.failure;
      EXPECT_NE(r.failure.find("exceeds the runaway limit 100 "), std::string::npos) << r.failure;
    }
}

TEST(DrivingForce, CliHugeForceExitsThreeAtStepTen) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {{"@G@", "1000.0"}}));
  expect_numerical_failure(r);
  EXPECT_NE(r.result.err.find("numerical failure: step 10: particle "), std::string::npos)
      << r.result.err;
}

TEST(DrivingForce, CliModerateForceWritesTheExactMomentum) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {{"@G@", "0.5"}}));
  const ms::ParticleSet p = expect_clean_run(r);
  const auto px = csv_column(r.out / "thermo.csv", "px");
  const auto steps = csv_column(r.out / "thermo.csv", "step");
  ASSERT_EQ(px.size(), steps.size());
  ASSERT_FALSE(px.empty());
  const double n = static_cast<double>(p.size());
  for (size_t k = 0; k < px.size(); ++k)
    EXPECT_NEAR(px[k], n * 0.5 * 0.01 * steps[k], 1e-6 * n) << "step " << steps[k];
}

}  // namespace
}  // namespace mesorock::stability
