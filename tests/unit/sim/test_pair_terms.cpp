// Unit tests of the force terms: antisymmetry, cutoff, coincident particles, -dU/dr, kernel
// normalisation.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/kernels.h"
#include "sim/pair_terms.h"
#include "sim/simulation.h"

namespace ms = mesorock::sim;

namespace {

// Two particles i = 0, j = 1 in a large non-periodic box; a view over small arrays.
struct PairFixture {
  double x[2] = {0, 0}, y[2] = {0, 0}, z[2] = {0, 0};
  double ve[6] = {0.3, -0.2, 0.1, -0.5, 0.4, 0.25};
  double rho[2] = {6.3, 7.1};
  std::int32_t type[2] = {0, 0};
  std::int64_t id[2] = {17, 4};
  ms::PairParams<double> p{-40, 25, 4.5, std::sqrt(9.0)};
  ms::StepView<double> view() {
    ms::StepView<double> v;
    v.n = 2;
    v.x = x, v.y = y, v.z = z;
    v.vex = ve, v.vey = ve + 2, v.vez = ve + 4;
    v.rho = rho;
    v.type = type;
    v.id = id;
    v.table = &p;
    v.ntypes = 1;
    v.rd = 0.75;
    v.inv_sqrt_dt = 10;
    v.seed = 99;
    v.step = 12345;
    return v;
  }
};

template <class C, class T>
ms::PairForce<double> force_between(PairFixture& f, int i, int j) {
  const auto v = f.view();
  const double dx = f.x[i] - f.x[j], dy = f.y[i] - f.y[j], dz = f.z[i] - f.z[j];
  return ms::pair_force<double, C, T>(v, ms::pair_side<double, C, T>(v, i),
                                      ms::pair_side<double, C, T>(v, j), dx, dy, dz,
                                      dx * dx + dy * dy + dz * dz);
}

using MDPD = ms::ConservativeMDPD<ms::DensityKernelWarren>;

TEST(PairTerms, EveryPartIsAntisymmetric) {
  PairFixture f;
  for (double r : {0.05, 0.3, 0.6, 0.74, 0.76, 0.9, 0.999}) {
    f.x[1] = r * 0.6, f.y[1] = r * 0.8;
    const auto a = force_between<MDPD, ms::DPDThermostat>(f, 0, 1);
    const auto b = force_between<MDPD, ms::DPDThermostat>(f, 1, 0);
    // Components along e_ij are equal, so F_ij = f e_ij = -(f e_ji) = -F_ji exactly.
    EXPECT_EQ(a.conservative, b.conservative) << "r = " << r;
    EXPECT_EQ(a.dissipative, b.dissipative) << "r = " << r;
    EXPECT_EQ(a.random, b.random) << "r = " << r;
    EXPECT_NE(a.random, 0.0);
  }
}

TEST(PairTerms, ZeroAtAndBeyondTheCutoff) {
  PairFixture f;
  // The formulas themselves vanish at r = rc = 1 ...
  EXPECT_EQ(MDPD::magnitude(1.0, f.rho[0], f.rho[1], f.p, 0.75), 0.0);
  EXPECT_EQ(ms::DPDThermostat::dissipative(1.0, 0.7, f.p), 0.0);
  EXPECT_EQ(ms::DPDThermostat::random(1.0, 0.9, 10.0, f.p), 0.0);
  EXPECT_EQ(ms::ConservativeDPD::magnitude(1.0, 0.0, 0.0, f.p, 0.75), 0.0);
  // ... the many-body part at rd ...
  ms::PairParams<double> only_b{0, 25, 0, 0};
  EXPECT_EQ(MDPD::magnitude(0.75, 6.0, 6.0, only_b, 0.75), 0.0);
  EXPECT_EQ(MDPD::magnitude(0.8, 6.0, 6.0, only_b, 0.75), 0.0);
  EXPECT_EQ(ms::DensityKernelWarren::weight(0.75, 0.75), 0.0);
  EXPECT_EQ(ms::DensityKernelLucy::weight(0.75, 0.75), 0.0);
  // ... and the whole force pass gives nothing at and beyond rc (thermostat and mDPD on).
  for (double r : {1.0, 1.0 + 1e-12, 1.5}) {
    ms::Model m;
    const int t = m.add_type({"fluid", false, {0, 0, 0}});
    m.set_pair(t, t, {-40, 25, 4.5});
    ms::BoxSpec box;
    box.hi = {10, 10, 10};
    ms::ParticleSet p;
    p.add(4, 5, 5, 0.3, 0, 0, t, 0);
    p.add(4 + r, 5, 5, -0.3, 0, 0, t, 1);
    const auto forces = ms::make_simulation(m, box, p, 0.01)->forces();
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(forces[a][0], 0.0) << "r = " << r;
      EXPECT_EQ(forces[a][1], 0.0) << "r = " << r;
    }
  }
}

TEST(PairTerms, CoincidentParticlesGiveFiniteForces) {
  PairFixture f;
  for (double r : {0.0, 1e-300, 1e-12, 1e-6}) {
    f.x[1] = r;
    const auto a = force_between<MDPD, ms::DPDThermostat>(f, 0, 1);
    EXPECT_TRUE(std::isfinite(a.conservative) && std::isfinite(a.dissipative) &&
                std::isfinite(a.random))
        << "r = " << r;
  }
  EXPECT_TRUE(std::isfinite(ms::DensityKernelWarren::weight(0.0, 0.75)));
  EXPECT_TRUE(std::isfinite(ms::DensityKernelLucy::weight(0.0, 0.75)));
}

// int_0^rd 4 pi r^2 w(r) dr = 1 (Simpson's rule, 2000 intervals).
template <class K>
double kernel_integral(double rd) {
  const int n = 2000;
  const double h = rd / n;
  double s = 0;
  for (int k = 0; k <= n; ++k) {
    const double r = k * h;
    const double f = 4 * M_PI * r * r * K::weight(r, rd);
    s += f * (k == 0 || k == n ? 1 : (k % 2 ? 4 : 2));
  }
  return s * h / 3;
}

TEST(PairTerms, DensityKernelsIntegrateToOne) {
  for (double rd : {0.5, 0.75, 1.0}) {
    EXPECT_NEAR(kernel_integral<ms::DensityKernelWarren>(rd), 1.0, 1e-9) << "rd = " << rd;
    EXPECT_NEAR(kernel_integral<ms::DensityKernelLucy>(rd), 1.0, 1e-9) << "rd = " << rd;
  }
}

TEST(PairTerms, DPDConservativeIsMinusDerivativeOfPotential) {
  // U(r) = a/2 (1 - r)^2.
  ms::PairParams<double> p{25, 0, 0, 0};
  const double h = 1e-6;
  for (double r : {0.1, 0.4, 0.8, 0.95}) {
    auto U = [&](double s) { return 0.5 * p.A * (1 - s) * (1 - s); };
    const double numeric = -(U(r + h) - U(r - h)) / (2 * h);
    EXPECT_NEAR(ms::ConservativeDPD::magnitude(r, 0.0, 0.0, p, 0.75), numeric, 1e-7);
  }
}

TEST(PairTerms, RandomNumbersAreSymmetricWithZeroMeanUnitVariance) {
  double sum = 0, sum2 = 0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const double a = ms::pair_random<double>(7, 3, k, k + 1000003);
    const double b = ms::pair_random<double>(7, 3, k + 1000003, k);
    ASSERT_EQ(a, b);
    sum += a;
    sum2 += a * a;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum2 / n, 1.0, 0.01);
  EXPECT_NE(ms::pair_random<double>(7, 3, 1, 2), ms::pair_random<double>(7, 4, 1, 2));
  EXPECT_NE(ms::pair_random<double>(7, 3, 1, 2), ms::pair_random<double>(8, 3, 1, 2));
  EXPECT_EQ(ms::pair_random<float>(7, 3, 1, 2),
            static_cast<float>(ms::pair_random<double>(7, 3, 1, 2)));
}

}  // namespace
