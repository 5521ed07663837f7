// Walls under high pressure: a rigid slab (piston, [[slabs]]) pushes the standard DPD fluid
// (a = 25) with P = 100, four times the pressure of the rigid-slab unit test, against a frozen
// lattice wall (z in [2, 4], the wall model of Li et al. 2018); z < 2 behind the wall is empty and
// the box faces in z are reflective (scene piston_wall.toml). No fluid particle may enter the wall
// deeper than 0.5 rc (z < 3.5) or pass it (z < 2). At P = 1000 the piston is accelerated past the
// runaway limit within about 100 steps: the run must stop there with the watchdog's diagnostic.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "piston_wall.toml";

std::vector<std::pair<std::string, std::string>> piston(const char* pressure, const char* steps) {
  // The fluid starts near the density that balances P = 100 (Groot & Warren: rho = 6.1).
  return {{"@PRESSURE@", pressure},
          {"@STEPS@", steps},
          {"@FLUID_TOP@", "9.0"},
          {"@PISTON_LO@", "9.2"},
          {"@PISTON_HI@", "10.7"}};
}

TEST(PistonWall, HundredTimesKbtPerRcCubedPushesNoFluidIntoTheWall) {
  SceneRun r = load_scene_run(kScene, piston("-100.0", "3000"));
  double lowest = 1e9;
  std::vector<double> T, piston_z;
  run_stages(r, 50, [&](size_t) {
    const ms::ParticleSet p = r.sim->particles();
    for (size_t i = 0; i < p.size(); ++i)
      if (p.type[i] == 0) lowest = std::min(lowest, p.z[i]);
    T.push_back(r.sim->kinetic_temperature());
    piston_z.push_back(r.sim->rigid_slabs().front().position);
  });
  EXPECT_EQ(r.failure, "");
  const size_t half = piston_z.size() / 2;
  const double z =
      mean(std::vector<double>(piston_z.begin() + static_cast<long>(half), piston_z.end()));
  // Fluid column between the wall surface (z = 4) and the piston's face (its mean z - 0.75).
  const double rho = 480 / (16 * (z - 0.75 - 4.0));
  report("piston P=100: lowest fluid z (wall surface at 4, far side at 2)", lowest);
  report("piston P=100: mean piston z, second half", z);
  report("piston P=100: fluid density from the piston position", rho);
  report("piston P=100: mean T", mean(T));
  report("piston P=100: wall-model corrections", static_cast<double>(r.sim->wall_corrections()));
  EXPECT_GT(lowest, 3.5) << "fluid leaked into the wall";
  EXPECT_NEAR(mean(T), 1.0, 0.2);
  // Groot & Warren's p(rho) = 100 at rho = 6.1; the column includes the structured layers at the
  // wall and the piston, so only the range is checked.
  EXPECT_GT(rho, 5.0);
  EXPECT_LT(rho, 7.5);
}

TEST(PistonWall, ThousandTimesKbtPerRcCubedStopsAtTheRunawayPiston) {
  SceneRun r = load_scene_run(kScene, piston("-1000.0", "2000"));
  double lowest = 1e9;
  run_stages(r, 10, [&](size_t) {
    const ms::ParticleSet p = r.sim->particles();
    for (size_t i = 0; i < p.size(); ++i)
      if (p.type[i] == 0) lowest = std::min(lowest, p.z[i]);
  });
  ASSERT_TRUE(is_watchdog_message(r.failure)) << "'" << r.failure << "'";
  report("piston P=1000: stopped at step", std::stod(r.failure.substr(5)));
  report("piston P=1000: lowest fluid z before the stop", lowest);
  EXPECT_GT(lowest, 3.5) << "fluid leaked into the wall before the stop";
}

TEST(PistonWall, CliHighPressureRunKeepsTheFluidOutOfTheWall) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, piston("-100.0", "2000")));
  const ms::ParticleSet p = expect_clean_run(r);
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == 0) EXPECT_GT(p.z[i], 3.5) << "particle " << p.id[i];
  EXPECT_GT(expect_finite_csv(r.out / "slabs.csv"), 0);
}

TEST(PistonWall, CliRunawayPistonExitsThree) {
  test::TempDir dir;
  expect_numerical_failure(rockflow_run(dir, scene_text(kScene, piston("-1000.0", "2000"))));
}

}  // namespace
}  // namespace mesorock::stability
