// Particles exactly on cell faces and on the box faces, the upper face included. The box
// [-3, 3]^3 has cells exactly 1 rc wide, so every integer coordinate is a cell face; half of the
// particles sit on integer points (x = 3 = hi included: on a periodic axis it is the same point
// as x = -3, on a reflective axis the solver moves it just inside), the other half at random. The
// first forces and mDPD densities must equal a brute-force sum over all pairs (minimum image),
// whatever the cell list made of the faces; then the run must stay finite and inside the box.
#include <gtest/gtest.h>

#include <random>

#include "scene_runs.h"
#include "sim/pair_terms.h"
#include "stability_support.h"

namespace mesorock::stability {
namespace {

// Integer points of [-3, 3]^3 (every axis includes both faces) and as many random points.
ms::ParticleSet on_faces(std::uint64_t seed) {
  ms::ParticleSet p;
  std::int64_t id = 0;
  for (int z = -3; z <= 3; ++z)
    for (int y = -3; y <= 3; ++y)
      for (int x = -3; x <= 3; ++x) p.add(x, y, z, 0, 0, 0, 0, id++);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-3, 3), v(-1, 1);
  for (int k = 0; k < 343; ++k) p.add(u(rng), u(rng), u(rng), v(rng), v(rng), v(rng), 0, id++);
  return p;
}

struct FaceSystem {
  ms::Model model;
  ms::BoxSpec box;
};

FaceSystem face_system(bool mdpd, std::array<bool, 3> periodic) {
  FaceSystem s;
  s.model.conservative = mdpd ? ms::ConservativeKind::MDPD : ms::ConservativeKind::DPD;
  s.model.thermostat = false;  // deterministic first forces for the brute-force comparison
  const int t = s.model.add_type({"fluid", false, {0, 0, 0}});
  s.model.set_pair(t, t, mdpd ? ms::PairSpec{-40, 25, 0} : ms::PairSpec{25, 0, 0});
  s.box.lo = {-3, -3, -3};
  s.box.hi = {3, 3, 3};
  s.box.periodic = periodic;
  return s;
}

// Where the solver stores a coordinate: on a periodic axis the upper face is the lower face.
double stored(double x, bool periodic) {
  return periodic && x >= 3.0 ? -3.0 : x;
}

// Brute force over all pairs: densities (Warren's kernel) and conservative forces.
void brute_force(const FaceSystem& s, const ms::ParticleSet& p, std::vector<double>& rho,
                 std::array<std::vector<double>, 3>& f) {
  const size_t n = p.size();
  const bool mdpd = s.model.conservative == ms::ConservativeKind::MDPD;
  const ms::PairSpec& q = s.model.pair(0, 0);
  auto separation = [&](size_t i, size_t j, double d[3]) {
    const std::vector<double>* c[3] = {&p.x, &p.y, &p.z};
    double r2 = 0;
    for (int a = 0; a < 3; ++a) {
      const bool per = s.box.periodic[static_cast<size_t>(a)];
      d[a] = stored((*c[a])[i], per) - stored((*c[a])[j], per);
      if (per) d[a] -= 6.0 * std::round(d[a] / 6.0);
      r2 += d[a] * d[a];
    }
    return r2;
  };
  rho.assign(n, 0);
  if (mdpd)
    for (size_t i = 0; i < n; ++i)
      for (size_t j = 0; j < n; ++j) {
        double d[3];
        const double r2 = separation(i, j, d);
        if (i != j && r2 < 0.75 * 0.75)
          rho[i] += ms::DensityKernelWarren::weight(std::sqrt(r2), 0.75);
      }
  for (auto& c : f) c.assign(n, 0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      double d[3];
      const double r2 = separation(i, j, d);
      if (i == j || r2 >= 1 || r2 < 1e-20) continue;
      const double r = std::sqrt(r2);
      double m = q.A * (1 - r);
      if (mdpd && r < 0.75) m += q.B * (rho[i] + rho[j]) * (1 - r / 0.75);
      for (int a = 0; a < 3; ++a) f[static_cast<size_t>(a)][i] += m * d[a] / r;
    }
}

TEST(Boundaries, FirstForcesAndDensitiesOnFacesMatchBruteForce) {
  for (const bool mdpd : {false, true})
    for (const bool periodic_x : {true, false}) {
      const FaceSystem s = face_system(mdpd, {periodic_x, true, false});
      ms::ParticleSet p = on_faces(41);
      if (periodic_x)  // the plane x = -3 would coincide with x = 3 = hi: keep the upper one
        for (size_t i = 0; i < p.size(); ++i)
          if (p.x[i] == -3.0) p.x[i] = 3.0;
      auto sim = ms::make_simulation(s.model, s.box, p, 0.01, cpu_options());
      std::vector<double> rho;
      std::array<std::vector<double>, 3> f;
      brute_force(s, p, rho, f);
      const auto got_f = sim->forces();
      const auto got_rho = sim->densities();
      double worst = 0;
      for (size_t i = 0; i < p.size(); ++i) {
        if (mdpd) worst = std::max(worst, std::abs(got_rho[i] - rho[i]));
        for (int a = 0; a < 3; ++a)
          worst = std::max(
              worst, std::abs(got_f[static_cast<size_t>(a)][i] - f[static_cast<size_t>(a)][i]));
      }
      const std::string label =
          std::string(mdpd ? "mdpd" : "dpd") + (periodic_x ? " periodic x" : " reflective x");
      report(label + ": largest |force or density - brute force|", worst);
      // A particle on a reflective upper face is moved inside by one ulp: differences of 1e-12.
      EXPECT_LT(worst, 1e-9) << label;
      const std::string failure = run_sampled(*sim, 300, 50);
      EXPECT_EQ(failure, "") << label;
      const ms::ParticleSet after = sim->particles();
      EXPECT_TRUE(all_finite(after));
      for (size_t i = 0; i < after.size(); ++i)
        for (const auto* c : {&after.x, &after.y, &after.z}) {
          EXPECT_GE((*c)[i], -3.0) << label;
          EXPECT_LT((*c)[i], 3.0) << label;
        }
    }
}

TEST(Boundaries, CliRunFromAParticleFileOnTheFaces) {
  for (const bool periodic_x : {true, false}) {
    test::TempDir dir;
    ms::ParticleSet p = on_faces(43);
    if (periodic_x)
      for (size_t i = 0; i < p.size(); ++i)
        if (p.x[i] == -3.0) p.x[i] = 3.0;
    ms::ParticleFileMeta meta;
    meta.type_names = {"fluid"};
    meta.box.lo = {-3, -3, -3};
    meta.box.hi = {3, 3, 3};
    ms::write_particle_file(dir / "particles.h5", p, meta);
    const CliRun r = rockflow_run(
        dir, scene_text("boundaries.toml", {{"@BX@", periodic_x ? "periodic" : "reflective"},
                                            {"@THERMOSTAT@", "true"},
                                            {"@GAMMA@", "gamma = 4.5"}}));
    const ms::ParticleSet after = expect_clean_run(r);
    ASSERT_EQ(after.size(), p.size());
    for (size_t i = 0; i < after.size(); ++i)
      for (const auto* c : {&after.x, &after.y, &after.z}) {
        EXPECT_GE((*c)[i], -3.0);
        EXPECT_LT((*c)[i], 3.0);
      }
  }
}

}  // namespace
}  // namespace mesorock::stability
