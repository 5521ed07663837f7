#include "sim/wall_geometry.h"

#include <cmath>
#include <functional>

#include "sim/wall_model.h"

namespace mesorock::sim {

namespace {

// Midpoint rule over r in (0, 1): integral of W(r) area(r) dr, area(r) the area of the sphere of
// radius r around the point that lies in the solid (W integrates to 1 over the unit ball).
double kernel_integral(const std::function<double(double r)>& solid_area) {
  constexpr int kSteps = 2000;
  double sum = 0;
  for (int k = 0; k < kSteps; ++k) {
    const double r = (k + 0.5) / kSteps;
    sum += bvf_weight(r) * solid_area(r);
  }
  return sum / kSteps;
}

double bisect(const std::function<double(double)>& f, double lo, double hi) {
  double flo = f(lo);
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi), fm = f(mid);
    if ((fm > 0) == (flo > 0)) {
      lo = mid;
      flo = fm;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

}  // namespace

double ball_boundary_fraction(double a, double D) {
  return kernel_integral([&](double r) {
    // Points x + r u with |x + r u - c| < a: cos(angle to the centre) > (D^2 + r^2 - a^2) / 2Dr.
    const double c0 = std::clamp((D * D + r * r - a * a) / (2 * D * r), -1.0, 1.0);
    return 2 * M_PI * r * r * (1 - c0);
  });
}

double tube_boundary_fraction(double R, double rho) {
  return kernel_integral([&](double r) {
    // u = (sin t cos p, sin t sin p, cos t), the axis along z, the point at (rho, 0, 0): in the
    // solid when cos p > (R^2 - rho^2 - r^2 sin^2 t) / (2 rho r sin t), a share arccos(c) / pi
    // of the circle of p.
    constexpr int kAngles = 400;
    double solid = 0;
    for (int k = 0; k < kAngles; ++k) {
      const double t = M_PI * (k + 0.5) / kAngles, st = std::sin(t);
      const double c =
          std::clamp((R * R - rho * rho - r * r * st * st) / (2 * rho * r * st), -1.0, 1.0);
      solid += 2 * std::acos(c) * st;
    }
    return r * r * solid * M_PI / kAngles;
  });
}

double ball_surface_offset(double a, double phi_c) {
  return bisect([&](double d) { return ball_boundary_fraction(a, a + d) - phi_c; }, -0.5, 0.5);
}

double tube_surface_offset(double R, double phi_c) {
  return bisect([&](double d) { return tube_boundary_fraction(R, R - d) - phi_c; }, -0.5, 0.5);
}

}  // namespace mesorock::sim
