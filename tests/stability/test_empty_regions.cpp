// Empty regions: the mDPD liquid (and a layer of a second liquid, "oil") fill only the lower half
// of the box (a virtual wall keeps them there), so the cells of the upper half hold no particle;
// a region of [[output.regions]]
// there counts nothing, and its density, flow rate and saturation must come out as 0 (not
// 0 / 0 = NaN) while the film's region counts every particle (scene empty_region.toml).
// Empty ranks belong to the MPI decomposition, not built yet; a simulation without any particle
// (what an empty rank will hold) is covered by the unit test
// Watchdog.EmptySystemRunsAndReportsNothing on every backend.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "empty_region.toml";

TEST(EmptyRegions, EmptyCellsAndAnEmptyRegionStayFinite) {
  SceneRun r = load_scene_run(kScene, {});
  ms::BinGrid vapour;
  vapour.lo = {0, 0, 6};
  vapour.hi = {5, 5, 7};
  vapour.type_mask = 3u;
  std::vector<double> T;
  double most_in_vapour = 0;
  run_stages(r, 50, [&](size_t stage) {
    const auto sums = r.sim->bin_sums(vapour);
    most_in_vapour = std::max(most_in_vapour, sums[ms::kBinCount]);
    if (stage == 1) T.push_back(r.sim->kinetic_temperature());
  });
  EXPECT_EQ(r.failure, "");
  report("empty region: most particles seen in the vapour region", most_in_vapour);
  report("empty region: mean T", mean(T));
  EXPECT_EQ(most_in_vapour, 0.0) << "a particle passed the virtual wall";
  EXPECT_NEAR(mean(T), 1.0, 0.08);
  EXPECT_TRUE(all_finite(r.sim->particles()));
}

TEST(EmptyRegions, CliWritesZerosNotNaNForTheEmptyRegion) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {}));
  const ms::ParticleSet p = expect_clean_run(r);
  EXPECT_GT(expect_finite_csv(r.out / "regions.csv"), 0);
  EXPECT_GT(expect_finite_csv(r.out / "saturation.csv"), 0);
  // Rows of the empty region: count, number density and flow rates all exactly 0; saturation 0
  // over 0 counted particles.
  const auto regions = test::read_file(r.out / "regions.csv");
  std::stringstream lines(regions);
  std::string line;
  int vapour_rows = 0;
  while (std::getline(lines, line)) {
    if (line.find(",vapour,") == std::string::npos) continue;
    ++vapour_rows;
    EXPECT_NE(line.find(",0,0,0,0,0"), std::string::npos) << line;
  }
  EXPECT_GT(vapour_rows, 0);
  const auto counted = csv_column(r.out / "saturation.csv", "counted");
  const auto saturation = csv_column(r.out / "saturation.csv", "saturation");
  ASSERT_EQ(counted.size(), saturation.size());
  double film_counted = 0;
  for (size_t k = 0; k < counted.size(); ++k) {
    EXPECT_TRUE(std::isfinite(saturation[k]));
    if (counted[k] == 0) EXPECT_EQ(saturation[k], 0.0);
    film_counted = std::max(film_counted, counted[k]);
  }
  EXPECT_GT(film_counted, 0.5 * static_cast<double>(p.size()));
}

}  // namespace
}  // namespace mesorock::stability
