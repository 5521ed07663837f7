// Time steps at and past the stable limit. The papers' mDPD liquid (A = -40, B = 25, rd = 0.75,
// gamma = 4.5, rho = 6.9; 442 particles in a periodic 4^3 box) runs at dt = 0.03 with its
// temperature 4% above kBT and at 0.035 with 11% above; from dt = 0.04 it blows up within about 50
// steps. Without the watchdog such a run does not reach NaN: the bounded mDPD forces let it settle
// as a gas at T ~ 600 and it would end "successfully" with meaningless outputs (docs/stability.md).
// The watchdog must stop it with a one-line diagnostic instead; the CLI exits 3 and leaves no
// output files.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "dt_limit_mdpd.toml";

// The run stage's temperatures (relax stage excluded), sampled every 50 steps.
struct TimeStepRun {
  std::string failure;
  std::vector<double> temperatures;
  std::uint64_t relax_steps = 0;
};

TimeStepRun run_at(double dt, ms::Precision precision, std::uint64_t steps = 2000) {
  SceneRun r = load_scene_run(kScene, {{"@DT@", std::to_string(dt)},
                                       {"steps = 1000", "steps = " + std::to_string(steps)},
                                       {"seed = 11", precision == ms::Precision::Single
                                                         ? "seed = 11\nprecision = \"single\""
                                                         : "seed = 11"}});
  TimeStepRun out;
  out.relax_steps = r.scene.stages.front().steps;
  run_stages(r, 50, [&](size_t stage) {
    if (stage == 1) out.temperatures.push_back(r.sim->kinetic_temperature());
  });
  out.failure = r.failure;
  if (r.failure.empty()) EXPECT_TRUE(all_finite(r.sim->particles()));
  return out;
}

TEST(TimeStep, MdpdAtTheStableLimitRunsWithItsTemperatureBounded) {
  // dt, allowed |T - kBT| / kBT: the discretisation heats the liquid as dt grows.
  for (const auto [dt, tolerance] : {std::pair{0.03, 0.06}, std::pair{0.035, 0.15}}) {
    const TimeStepRun r = run_at(dt, ms::Precision::Double);
    EXPECT_EQ(r.failure, "") << "dt = " << dt;
    const double T = mean(r.temperatures);
    report("mdpd dt=" + std::to_string(dt) + " mean T", T);
    EXPECT_NEAR(T, 1.0, tolerance) << "dt = " << dt;
  }
}

TEST(TimeStep, MdpdPastTheStableLimitStopsWithADiagnosticInEitherPrecision) {
  for (const double dt : {0.04, 0.05, 0.08})
    for (const auto precision : {ms::Precision::Double, ms::Precision::Single}) {
      const TimeStepRun r = run_at(dt, precision, 1000);
      ASSERT_TRUE(is_watchdog_message(r.failure))
          << "dt = " << dt << " " << ms::to_string(precision) << ": '" << r.failure << "'";
      const std::uint64_t step = std::stoull(r.failure.substr(5));
      report("mdpd dt=" + std::to_string(dt) + " " + ms::to_string(precision) + " stopped at step",
             static_cast<double>(step));
      EXPECT_GT(step, r.relax_steps) << "the relax stage (dt = 0.005) must run through";
      // Stopped early: the samples before the blow-up are finite.
      for (double T : r.temperatures) EXPECT_TRUE(std::isfinite(T));
    }
}

// Standard DPD (a = 25, rho = 3) is far more forgiving: at the scene's largest dt (0.1) it still
// runs, 34% hot; the watchdog stops it past the limit.
TEST(TimeStep, DpdRunsHotUpToTheSceneLimitAndStopsBeyondIt) {
  const double L[3] = {5, 5, 5};
  for (const auto [dt, tolerance] :
       {std::pair{0.04, 0.03}, std::pair{0.06, 0.1}, std::pair{0.1, 0.45}}) {
    BuiltSystem s = pipeline::make_bulk_dpd(25, 4.5, 3, L, 7);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, cpu_options());
    sim->run(300);
    sim->set_dt(dt);
    std::vector<double> T;
    const std::string failure =
        run_sampled(*sim, 1500, 50, [&] { T.push_back(sim->kinetic_temperature()); });
    EXPECT_EQ(failure, "") << "dt = " << dt;
    report("dpd dt=" + std::to_string(dt) + " mean T", mean(T));
    EXPECT_NEAR(mean(T), 1.0, tolerance) << "dt = " << dt;
  }
  for (const double dt : {0.2, 0.3}) {
    BuiltSystem s = pipeline::make_bulk_dpd(25, 4.5, 3, L, 7);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, cpu_options());
    sim->run(300);
    sim->set_dt(dt);
    const std::string failure = run_sampled(*sim, 3000, 100);
    EXPECT_TRUE(is_watchdog_message(failure)) << "dt = " << dt << ": '" << failure << "'";
    report("dpd dt=" + std::to_string(dt) + " stopped at step",
           failure.empty() ? -1.0 : std::stod(failure.substr(5)));
  }
}

TEST(TimeStep, CliAtTheLimitWritesFiniteOutputs) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {{"@DT@", "0.03"}}));
  expect_clean_run(r);
  const auto T = csv_column(r.out / "thermo.csv", "temperature");
  ASSERT_GT(T.size(), 10u);
  const double late = mean(std::vector<double>(T.end() - 10, T.end()));
  report("cli mdpd dt=0.03 mean T of the last 10 rows", late);
  EXPECT_NEAR(late, 1.0, 0.08);
}

TEST(TimeStep, CliPastTheLimitExitsThreeNamingStepParticleAndQuantity) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {{"@DT@", "0.05"}}));
  expect_numerical_failure(r);
}

}  // namespace
}  // namespace mesorock::stability
