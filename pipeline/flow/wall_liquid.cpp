#include "pipeline/flow/wall_liquid.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "sim/simulation.h"
#include "sim/wall_model.h"

namespace mesorock::pipeline::wall_liquid {

// Walls are frozen liquid: this is the packing of Liu et al. that the 2020 paper describes,
// affordable here because the boxes are small; it gives the wall the liquid's own structure and
// density, which is what the wall model's no-slip derivation assumes.
BuiltSystem liquid_with_walls(const double L[3], const std::array<bool, 3>& periodic,
                              const SolidDepth& depth, double thickness, std::uint64_t equilibrate,
                              std::uint64_t seed, const ValidateOptions& o) {
  BuiltSystem bulk = make_bulk_mdpd(kA, kB, kRd, kGamma, kRho, L, seed, o.density_kernel);
  {
    auto sim = sim::make_simulation(bulk.model, bulk.box, bulk.particles, 0.01, o.sim);
    sim->run(equilibrate);
    bulk.particles = sim->particles();
  }
  BuiltSystem s;
  s.model = bulk.model;
  s.model.add_type({"wall", true, {0, 0, 0}});
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) s.model.set_pair(a, b, {kA, kB, kGamma});
  s.model.wall_model.enabled = true;
  s.model.wall_model.wall_density = kRho;  // the frozen liquid keeps the liquid's density
  s.box = bulk.box;
  s.box.periodic = periodic;
  const sim::ParticleSet& p = bulk.particles;
  for (size_t i = 0; i < p.size(); ++i) {
    const double d = depth(p.x[i], p.y[i], p.z[i]);
    if (d > thickness) continue;
    const bool wall = d > 0;
    s.particles.add(p.x[i], p.y[i], p.z[i], wall ? 0 : p.vx[i], wall ? 0 : p.vy[i],
                    wall ? 0 : p.vz[i], wall ? 1 : 0, p.id[i]);
  }
  return s;
}

namespace {

// Midpoint rule over r in (0, 1): integral of W(r) area(r) dr, area(r) the area of the sphere of
// radius r around the point that lies in the solid (W integrates to 1 over the unit ball).
double kernel_integral(const std::function<double(double r)>& solid_area) {
  constexpr int kSteps = 2000;
  double sum = 0;
  for (int k = 0; k < kSteps; ++k) {
    const double r = (k + 0.5) / kSteps;
    sum += sim::bvf_weight(r) * solid_area(r);
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

}  // namespace mesorock::pipeline::wall_liquid
