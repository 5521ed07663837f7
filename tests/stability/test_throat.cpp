// One-voxel throats: a solid block of frozen lattice wall (x in [3, 5], the wall model of Li et al.
// 2018) leaves one gap 1 rc wide (z in [3.5, 4.5]) through which a body force drives the mDPD
// liquid (scene throat.toml). The liquid must keep out of the solid (no particle deeper than
// 0.5 rc inside it), keep flowing through the gap, and keep a bounded temperature.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "throat.toml";

// Depth of a point inside the solid block (> 0 inside; z is periodic with period 8).
double solid_depth(double x, double z) {
  const double dz = std::abs(z - 4.0);
  return std::min({x - 3.0, 5.0 - x, dz - 0.5});
}

struct ThroatResult {
  std::string failure;
  double deepest = -1e9;          // largest depth of a liquid particle inside the solid
  int in_gap_min = 1 << 30;       // fewest liquid particles in the gap at a sample
  std::vector<double> flow_vx;    // mean liquid vx per sample of the flow stage
  std::vector<double> flow_temp;  // kinetic temperature per sample of the flow stage
};

ThroatResult run_throat(const std::string& g) {
  SceneRun r = load_scene_run(kScene, {{"@G@", g}});
  ThroatResult out;
  run_stages(r, 100, [&](size_t stage) {
    const ms::ParticleSet p = r.sim->particles();
    int in_gap = 0;
    double vx = 0;
    int liquid = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      if (p.type[i] != 0) continue;
      out.deepest = std::max(out.deepest, solid_depth(p.x[i], p.z[i]));
      in_gap += p.x[i] > 3 && p.x[i] < 5 && std::abs(p.z[i] - 4.0) < 0.5;
      vx += p.vx[i];
      ++liquid;
    }
    if (stage == 1) {
      out.in_gap_min = std::min(out.in_gap_min, in_gap);
      out.flow_vx.push_back(vx / liquid);
      out.flow_temp.push_back(r.sim->kinetic_temperature());
    }
  });
  out.failure = r.failure;
  return out;
}

TEST(Throat, LiquidFlowsThroughAOneVoxelGapWithoutEnteringTheSolid) {
  for (const char* g : {"0.5", "2.0"}) {
    const ThroatResult r = run_throat(g);
    EXPECT_EQ(r.failure, "") << "g = " << g;
    report(std::string("throat g=") + g + " deepest liquid particle inside the solid (rc)",
           r.deepest);
    report(std::string("throat g=") + g + " fewest liquid particles in the gap", r.in_gap_min);
    report(std::string("throat g=") + g + " mean liquid vx", mean(r.flow_vx));
    report(std::string("throat g=") + g + " mean T", mean(r.flow_temp));
    EXPECT_LT(r.deepest, 0.5) << "g = " << g;
    EXPECT_GT(r.in_gap_min, 0) << "g = " << g;
    EXPECT_GT(mean(r.flow_vx), 0) << "g = " << g;
    // The kinetic temperature here includes the flow's own kinetic energy (the jet through the
    // gap), so it reads above kBT as the force grows; it must stay bounded.
    EXPECT_GT(mean(r.flow_temp), 0.9) << "g = " << g;
    EXPECT_LT(mean(r.flow_temp), 1.4) << "g = " << g;
  }
}

TEST(Throat, CliRunKeepsTheLiquidOutOfTheSolid) {
  test::TempDir dir;
  const CliRun r = rockflow_run(dir, scene_text(kScene, {{"@G@", "2.0"}}));
  const ms::ParticleSet p = expect_clean_run(r);
  double deepest = -1e9;
  for (size_t i = 0; i < p.size(); ++i)
    if (p.type[i] == 0) deepest = std::max(deepest, solid_depth(p.x[i], p.z[i]));
  EXPECT_LT(deepest, 0.5);
}

}  // namespace
}  // namespace mesorock::stability
