// Strongly compressed fluid. The standard DPD fluid (a = 25, gamma = 4.5) at twice its usual
// density must keep to Groot & Warren's equation of state (J. Chem. Phys. 107, 4423 (1997)): at
// rho = 3 their measured p = 23.65 (2%), at rho = 6 their fit p = rho + alpha a rho^2 with
// alpha = 0.101 (96.9; 3%). The papers' mDPD liquid (zero-pressure density 6.9) started at
// rho = 10 and 14 must keep its temperature.
#include <gtest/gtest.h>

#include <tuple>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

TEST(Compressed, DpdAtTwiceItsUsualDensityFollowsTheEquationOfState) {
  const double L[3] = {5, 5, 5};
  // rho, reference pressure, relative tolerance
  for (const auto [rho, expected, tolerance] :
       {std::tuple{3.0, 23.65, 0.02}, std::tuple{6.0, 6.0 + 0.101 * 25 * 36, 0.03}}) {
    BuiltSystem s = pipeline::make_bulk_dpd(25, 4.5, rho, L, 31);
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.005, cpu_options());
    sim->run(400);
    sim->set_dt(0.01);
    std::vector<double> p, T;
    const std::string failure = run_sampled(*sim, 3000, 20, [&] {
      p.push_back(sim->stress().pressure_conservative());
      T.push_back(sim->kinetic_temperature());
    });
    EXPECT_EQ(failure, "");
    report("dpd rho=" + std::to_string(rho) + " pressure", mean(p));
    report("dpd rho=" + std::to_string(rho) + " pressure, Groot & Warren", expected);
    report("dpd rho=" + std::to_string(rho) + " mean T", mean(T));
    EXPECT_NEAR(mean(p), expected, tolerance * expected) << "rho = " << rho;
    EXPECT_NEAR(mean(T), 1.0, 0.03) << "rho = " << rho;
  }
}

TEST(Compressed, MdpdLiquidFarAboveItsDensityKeepsItsTemperature) {
  for (const char* rho : {"10.0", "14.0"}) {
    SceneRun r = load_scene_run("compressed.toml", {{"@RHO@", rho}, {"@DT@", "0.01"}});
    std::vector<double> p, T;
    run_stages(r, 50, [&](size_t stage) {
      if (stage == 0) return;
      p.push_back(r.sim->stress().pressure());
      T.push_back(r.sim->kinetic_temperature());
    });
    EXPECT_EQ(r.failure, "") << "rho = " << rho;
    report(std::string("mdpd rho=") + rho + " pressure", mean(p));
    report(std::string("mdpd rho=") + rho + " mean T", mean(T));
    EXPECT_NEAR(mean(T), 1.0, 0.05) << "rho = " << rho;
    EXPECT_GT(mean(p), 0) << "compressed far above its zero-pressure density";
  }
}

TEST(Compressed, CliMdpdAtRhoTenRunsClean) {
  test::TempDir dir;
  const CliRun r =
      rockflow_run(dir, scene_text("compressed.toml", {{"@RHO@", "10.0"}, {"@DT@", "0.01"}}));
  expect_clean_run(r);
  const auto T = csv_column(r.out / "thermo.csv", "temperature");
  ASSERT_GT(T.size(), 10u);
  EXPECT_NEAR(mean(std::vector<double>(T.end() - 10, T.end())), 1.0, 0.08);
}

}  // namespace
}  // namespace mesorock::stability
