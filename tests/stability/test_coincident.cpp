// Coincident particles (r = 0). A pair at zero separation has no direction: the kernels give it no
// force (sim/kernels.h coincident_r2) rather than 0/0 = NaN. Two identical lattice blocks put
// every particle exactly on a twin (scene coincident.toml); the twins' other neighbours pull them
// apart (their velocities and random forces differ), and the run must stay finite with its
// temperature. A cluster of 20 particles at one point inside a liquid must not blow up either.
#include <gtest/gtest.h>

#include "scene_runs.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

const char* const kScene = "coincident.toml";

std::vector<std::pair<std::string, std::string>> twins(bool mdpd) {
  if (mdpd)
    return {{"@CONSERVATIVE@", "mdpd"}, {"@PAIR@", "A = -40.0\nB = 25.0"}, {"@DENSITY@", "3.45"}};
  return {{"@CONSERVATIVE@", "dpd"}, {"@PAIR@", "a = 25.0"}, {"@DENSITY@", "1.5"}};
}

// Smallest distance between two particles (minimum image, periodic box of edge 5).
double closest_pair(const ms::ParticleSet& p) {
  double best = 1e9;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) {
      double r2 = 0;
      for (const auto* c : {&p.x, &p.y, &p.z}) {
        double d = (*c)[i] - (*c)[j];
        d -= 5.0 * std::round(d / 5.0);
        r2 += d * d;
      }
      best = std::min(best, r2);
    }
  return std::sqrt(best);
}

TEST(Coincident, TwinLatticeSeparatesAndStaysFinite) {
  for (const bool mdpd : {false, true}) {
    SceneRun r = load_scene_run(kScene, twins(mdpd));
    const std::string kind = mdpd ? "mdpd" : "dpd";
    EXPECT_EQ(closest_pair(r.initial), 0.0);
    // The first forces (every particle at r = 0 from its twin) are finite.
    const auto f = r.sim->forces();
    for (const auto& c : f)
      for (double v : c) ASSERT_TRUE(std::isfinite(v));
    std::vector<double> T;
    run_stages(r, 50, [&](size_t) { T.push_back(r.sim->kinetic_temperature()); });
    EXPECT_EQ(r.failure, "") << kind;
    const ms::ParticleSet p = r.sim->particles();
    EXPECT_TRUE(all_finite(p));
    const double closest = closest_pair(p);
    report(kind + " twins: closest pair after 500 steps (rc)", closest);
    report(kind + " twins: mean T", mean(T));
    EXPECT_GT(closest, 1e-3) << kind;
    EXPECT_NEAR(mean(std::vector<double>(T.begin() + 2, T.end())), 1.0, 0.1) << kind;
  }
}

// 20 particles at one point inside a liquid, at rest. In standard DPD (bounded pair forces) the
// cluster dissolves and the run goes on. In mDPD each of them sees a density of about 110 (19
// coincident neighbours at the kernel's peak), so the many-body repulsion throws its neighbours
// out faster than 1 rc per step at the first step: the watchdog must stop that run, naming the
// step and a particle, rather than let it continue as a hot gas.
TEST(Coincident, ClusterAtOnePointDissolvesInDpdAndStopsTheMdpdRun) {
  const double L[3] = {5, 5, 5};
  for (const bool mdpd : {false, true}) {
    BuiltSystem s = mdpd ? pipeline::make_bulk_mdpd(-40, 25, 0.75, 4.5, 6.9, L, 37,
                                                    ms::DensityKernelKind::Warren)
                         : pipeline::make_bulk_dpd(25, 4.5, 3, L, 37);
    for (size_t i = 0; i < 20; ++i) {
      s.particles.x[i] = 2.5;
      s.particles.y[i] = 2.5;
      s.particles.z[i] = 2.5;
      s.particles.vx[i] = s.particles.vy[i] = s.particles.vz[i] = 0;  // only forces can split them
    }
    auto sim = ms::make_simulation(s.model, s.box, s.particles, 0.005, cpu_options());
    std::vector<double> T;
    const std::string failure =
        run_sampled(*sim, 1000, 100, [&] { T.push_back(sim->kinetic_temperature()); });
    if (!mdpd) {
      EXPECT_EQ(failure, "");
      EXPECT_TRUE(all_finite(sim->particles()));
      // The cluster's potential energy (190 pairs at a / 2 each) heats the fluid at first; the
      // thermostat takes it out again.
      report("dpd 20-particle cluster: T at step 100", T.front());
      const double late = mean(std::vector<double>(T.begin() + 5, T.end()));
      report("dpd 20-particle cluster: mean T, steps 600-1000", late);
      EXPECT_NEAR(late, 1.0, 0.1);
    } else {
      EXPECT_TRUE(is_watchdog_message(failure)) << "'" << failure << "'";
      EXPECT_EQ(failure.rfind("step 1: particle ", 0), 0u) << failure;
      std::printf("[ stability ] mdpd 20-particle cluster: %s\n", failure.c_str());
    }
  }
}

TEST(Coincident, CliTwinLatticeRunsClean) {
  for (const bool mdpd : {false, true}) {
    test::TempDir dir;
    expect_clean_run(rockflow_run(dir, scene_text(kScene, twins(mdpd))));
  }
}

}  // namespace
}  // namespace mesorock::stability
