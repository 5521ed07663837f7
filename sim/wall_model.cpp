#include "sim/wall_model.h"

#include <algorithm>
#include <cmath>

namespace mesorock::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Integrals over the cap d_z > h of the unit ball, in cylinders around the normal: the BVF
// kernel W, and w_D e_x^2 and w_D e_x^2 d_z with e_x^2 averaged over the azimuth (rho^2 / 2 r^2).
// Midpoint rule; 200 x 200 points give about 4 correct digits, far below what the tabulation
// needs.
struct CapIntegrals {
  double w = 0, j0 = 0, j1 = 0;
};

CapIntegrals cap_integrals(double h) {
  CapIntegrals c;
  const int nz = 200, nr = 200;
  const double dz = (1.0 - h) / nz;
  for (int a = 0; a < nz; ++a) {
    const double z = h + (a + 0.5) * dz;
    const double rho_max = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double dr = rho_max / nr;
    for (int b = 0; b < nr; ++b) {
      const double rho = (b + 0.5) * dr;
      const double r = std::sqrt(rho * rho + z * z);
      if (r >= 1.0) continue;
      const double wd = (1.0 - r) * (1.0 - r);
      const double ring = 2.0 * kPi * rho * dr * dz;
      const double ex2 = 0.5 * rho * rho / (r * r);
      c.w += bvf_weight(r) * ring;
      c.j0 += wd * ex2 * ring;
      c.j1 += wd * ex2 * z * ring;
    }
  }
  return c;
}

}  // namespace

double flat_wall_phi(double h) {
  const double x = std::max(0.0, h);
  if (x >= 1.0) return 0.0;
  const double x2 = x * x, x3 = x2 * x, x5 = x3 * x2, x6 = x5 * x, x7 = x6 * x;
  return 0.5 - 21.0 / 16 * x + 35.0 / 16 * x3 - 63.0 / 16 * x5 + 3.5 * x6 - 15.0 / 16 * x7;
}

FlatWallRelation flat_wall_relation(double h) {
  FlatWallRelation f;
  if (h >= 1.0) return f;
  const CapIntegrals c = cap_integrals(std::max(h, 0.0));
  f.phi = c.w;  // the kernel integrates to 1 over the ball: no normalisation needed
  f.kappa = h > 0 ? c.j1 / (h * c.j0) : HUGE_VAL;
  return f;
}

std::vector<double> tabulate_kappa(int entries, double phi_max, double kappa_max) {
  // phi(h) falls monotonically from 1/2 at h = 0 to 0 at h = 1: sample h finely, then
  // interpolate kappa at the wanted phi.
  const int samples = 401;
  std::vector<double> phi(samples), kappa(samples);
  for (int k = 0; k < samples; ++k) {
    const double h = static_cast<double>(k) / (samples - 1);
    const FlatWallRelation f = flat_wall_relation(h);
    phi[k] = f.phi;
    kappa[k] = std::min(f.kappa, kappa_max);
  }
  std::vector<double> table(static_cast<size_t>(entries));
  for (int e = 0; e < entries; ++e) {
    const double target = phi_max * e / (entries - 1);
    // phi is decreasing in h: find the first sample with phi <= target.
    int k = 0;
    while (k < samples - 1 && phi[k] > target) ++k;
    if (k == 0) {
      table[e] = kappa[0];
      continue;
    }
    const double t = (phi[k - 1] - target) / (phi[k - 1] - phi[k]);
    table[e] = kappa[k - 1] + t * (kappa[k] - kappa[k - 1]);
  }
  return table;
}

}  // namespace mesorock::sim
