// A long run: the drift of the total energy without a thermostat (standard DPD, whose potential
// U = sum a/2 (1 - r)^2 the test sums over all pairs) and of the temperature with one (the mDPD
// liquid), reported and bounded. Velocity Verlet conserves the energy up to O(dt^2) fluctuations
// without a systematic drift; the thermostat holds T at kBT up to the O(dt) offset of the
// time-step test.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

// Total energy per particle of a standard DPD system (m = 1; periodic cube of edge L).
double dpd_energy(const ms::ParticleSet& p, double a, double L) {
  double kinetic = 0, potential = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    kinetic += 0.5 * (p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i]);
    for (size_t j = i + 1; j < p.size(); ++j) {
      double r2 = 0;
      for (const auto* c : {&p.x, &p.y, &p.z}) {
        double d = (*c)[i] - (*c)[j];
        d -= L * std::round(d / L);
        r2 += d * d;
      }
      if (r2 < 1) {
        const double s = 1 - std::sqrt(r2);
        potential += 0.5 * a * s * s;
      }
    }
  }
  return (kinetic + potential) / static_cast<double>(p.size());
}

TEST(LongRun, EnergyWithoutAThermostatDriftsLessThanATenthOfAPercent) {
  const double L[3] = {5, 5, 5};
  for (const auto precision : {ms::Precision::Double, ms::Precision::Single}) {
    BuiltSystem s = pipeline::make_bulk_dpd(25, 0, 3, L, 47);  // gamma = 0: no thermostat
    s.model.precision = precision;
    // Settle the random start with a thermostat first, so the energy run starts in equilibrium.
    {
      BuiltSystem warm = pipeline::make_bulk_dpd(25, 4.5, 3, L, 47);
      auto sim = ms::make_simulation(warm.model, warm.box, warm.particles, 0.01, cpu_options());
      sim->run(500);
      s.particles = sim->particles();
    }
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.01, cpu_options());
    std::vector<double> E;
    const std::string failure =
        run_sampled(*sim, 20000, 500, [&] { E.push_back(dpd_energy(sim->particles(), 25, 5)); });
    EXPECT_EQ(failure, "");
    const double first = mean(std::vector<double>(E.begin(), E.begin() + 8));
    const double last = mean(std::vector<double>(E.end() - 8, E.end()));
    double spread = 0;
    for (double e : E) spread = std::max(spread, std::abs(e - first));
    const std::string label =
        std::string("nve dpd dt=0.01 20000 steps, ") + ms::to_string(precision);
    report(label + ": energy per particle", first);
    report(label + ": relative drift (last 4000 steps vs first 4000)", (last - first) / first);
    report(label + ": largest relative excursion", spread / first);
    EXPECT_LT(std::abs(last - first) / first, 1e-3) << label;
    EXPECT_LT(spread / first, 3e-3) << label;
  }
}

TEST(LongRun, TemperatureWithTheThermostatHoldsWithoutDrift) {
  SceneRun r =
      load_scene_run("dt_limit_mdpd.toml", {{"@DT@", "0.01"}, {"steps = 1000", "steps = 20000"}});
  std::vector<double> T;
  run_stages(r, 50, [&](size_t stage) {
    if (stage == 1) T.push_back(r.sim->kinetic_temperature());
  });
  EXPECT_EQ(r.failure, "");
  const size_t quarter = T.size() / 4;
  const double first = mean(std::vector<double>(T.begin(), T.begin() + quarter));
  const double last = mean(std::vector<double>(T.end() - quarter, T.end()));
  report("mdpd dt=0.01 20000 steps: mean T, first quarter", first);
  report("mdpd dt=0.01 20000 steps: mean T, last quarter", last);
  EXPECT_NEAR(first, 1.0, 0.03);
  EXPECT_NEAR(last, 1.0, 0.03);
  EXPECT_LT(std::abs(last - first), 0.02);
}

TEST(LongRun, CliTemperatureColumnHasNoDrift) {
  test::TempDir dir;
  const CliRun r = rockflow_run(
      dir, scene_text("dt_limit_mdpd.toml", {{"@DT@", "0.01"}, {"steps = 1000", "steps = 10000"}}));
  expect_clean_run(r);
  const auto T = csv_column(r.out / "thermo.csv", "temperature");
  ASSERT_GT(T.size(), 100u);
  const size_t quarter = T.size() / 4;
  const double first = mean(std::vector<double>(T.begin() + 10, T.begin() + 10 + quarter));
  const double last = mean(std::vector<double>(T.end() - quarter, T.end()));
  report("cli mdpd dt=0.01 10000 steps: T drift (last quarter - first)", last - first);
  EXPECT_LT(std::abs(last - first), 0.03);
}

}  // namespace
}  // namespace mesorock::stability
