// The wall model's surface on curved walls (sim/wall_geometry.h): the boundary volume fraction phi
// next to a solid ball and inside a tube, from the quadratures, against an independent Monte
// Carlo integral of the Lucy kernel over the solid; the flat-wall limit phi = 1/2 on the cut; the
// phi = 1/2 surface lies inside a convex wall and inside the pore of a concave one.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "sim/wall_geometry.h"
#include "sim/wall_model.h"

namespace wl = mesorock::sim;

namespace {

// phi at the origin for a solid given by in_solid(x, y, z): uniform points in the unit ball.
// Also gives the estimate's standard error (about 0.002 with 4e5 points).
struct MonteCarlo {
  double phi = 0, error = 0;
};
MonteCarlo monte_carlo_phi(const std::function<bool(double, double, double)>& in_solid) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const int n = 400000;
  const double volume = 4.0 / 3.0 * M_PI;
  double sum = 0, sum2 = 0;
  int inside = 0;
  while (inside < n) {
    const double x = u(rng), y = u(rng), z = u(rng), r = std::sqrt(x * x + y * y + z * z);
    if (r >= 1) continue;
    ++inside;
    if (in_solid(x, y, z)) {
      const double v = volume * mesorock::sim::bvf_weight(r);
      sum += v;
      sum2 += v * v;
    }
  }
  const double mean = sum / n;
  return {mean, std::sqrt((sum2 / n - mean * mean) / n)};
}

TEST(WallGeometry, BoundaryFractionAgreesWithMonteCarlo) {
  for (double d : {0.0, -0.1, 0.2}) {
    const double a = 2.5, D = a + d;  // the point at distance D from the ball's centre (D, 0, 0)
    const MonteCarlo mc = monte_carlo_phi(
        [&](double x, double y, double z) { return (x + D) * (x + D) + y * y + z * z < a * a; });
    // Four standard errors of the estimate (a quadrature error would be systematic and larger).
    EXPECT_NEAR(wl::ball_boundary_fraction(a, D), mc.phi, 4 * mc.error) << "ball, d = " << d;
  }
  for (double d : {0.0, 0.1, -0.2}) {
    const double R = 3, rho = R - d;  // the point at distance rho from the tube's axis
    const MonteCarlo mc = monte_carlo_phi(
        [&](double x, double y, double) { return (x + rho) * (x + rho) + y * y > R * R; });
    EXPECT_NEAR(wl::tube_boundary_fraction(R, rho), mc.phi, 4 * mc.error) << "tube, d = " << d;
  }
}

TEST(WallGeometry, FlatLimitAndCurvedSurfaces) {
  EXPECT_NEAR(wl::ball_boundary_fraction(1e5, 1e5), 0.5, 1e-4);
  EXPECT_NEAR(wl::tube_boundary_fraction(1e5, 1e5), 0.5, 1e-4);
  // Convex: the cut sees less than half the kernel in the solid, so phi = 1/2 lies inside the
  // ball; concave: the other way. Both shrink as the radius grows (about 0.09 rc^2 / radius).
  const double b25 = wl::ball_surface_offset(2.5), b45 = wl::ball_surface_offset(4.5);
  const double t3 = wl::tube_surface_offset(3), t6 = wl::tube_surface_offset(6);
  EXPECT_LT(b25, b45);
  EXPECT_LT(b45, 0);
  EXPECT_GT(t3, t6);
  EXPECT_GT(t6, 0);
  EXPECT_NEAR(b25, -0.036, 0.002);
  EXPECT_NEAR(t3, 0.015, 0.002);
  EXPECT_NEAR(wl::ball_boundary_fraction(2.5, 2.5 + b25), 0.5, 1e-9);
  EXPECT_NEAR(wl::ball_surface_offset(1e5), 0, 1e-4);
}

}  // namespace
