#pragma once
// Weighted least-squares fits of a flow rate q against a driving gradient G (permeability
// sweeps, the darcy-linearity case): Darcy's law through the origin, a straight line with an
// intercept (to test that the line goes through the origin), and a quadratic through the origin
// (the Forchheimer-type departure from Darcy). Each point carries one standard error; weights
// are 1 / error^2, and the parameter errors come from the inverse normal matrix (they assume the
// points' errors are right and independent; chi2 says whether the model fits within them).
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mesorock/errors.h"

namespace mesorock::pipeline {

// y = intercept + slope x (intercept fixed at 0 by fit_proportional).
struct LineFit {
  double intercept = 0, intercept_error = 0;
  double slope = 0, slope_error = 0;
  double covariance = 0;  // of intercept and slope
  double chi2 = 0;
  int dof = 0;
};

// y = c1 x + c2 x^2.
struct QuadraticFit {
  double c1 = 0, c1_error = 0;
  double c2 = 0, c2_error = 0;
  double covariance = 0;  // of c1 and c2
  double chi2 = 0;
  int dof = 0;
  // Relative departure of the quadratic from its linear part at x: c2 x / c1, and its error.
  double departure(double x) const { return c2 * x / c1; }
  double departure_error(double x) const {
    // d/dc1 = -c2 x / c1^2, d/dc2 = x / c1.
    const double a = -c2 * x / (c1 * c1), b = x / c1;
    const double v =
        a * a * c1_error * c1_error + b * b * c2_error * c2_error + 2 * a * b * covariance;
    return v > 0 ? std::sqrt(v) : 0.0;
  }
};

namespace fit_detail {
inline void check(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& err, std::size_t min_points, const char* what) {
  if (x.size() != y.size() || x.size() != err.size())
    throw ConfigError(std::string(what) + ": x, y and errors differ in length");
  if (x.size() < min_points)
    throw ConfigError(std::string(what) + ": needs at least " + std::to_string(min_points) +
                      " points");
  for (double e : err)
    if (!(e > 0) || !std::isfinite(e))
      throw ConfigError(std::string(what) + ": every point needs a positive error bar");
}
// Solves the 2 x 2 weighted normal equations for y = a f(x) + b g(x).
template <class F, class G>
void solve2(const std::vector<double>& x, const std::vector<double>& y,
            const std::vector<double>& err, F f, G g, double& a, double& b, double& va, double& vb,
            double& cov, double& chi2) {
  double S[3] = {0, 0, 0}, T[2] = {0, 0};
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double w = 1 / (err[k] * err[k]), fk = f(x[k]), gk = g(x[k]);
    S[0] += w * fk * fk;
    S[1] += w * fk * gk;
    S[2] += w * gk * gk;
    T[0] += w * fk * y[k];
    T[1] += w * gk * y[k];
  }
  const double det = S[0] * S[2] - S[1] * S[1];
  if (!(std::abs(det) > 0)) throw ConfigError("fit: the points do not determine the parameters");
  a = (S[2] * T[0] - S[1] * T[1]) / det;
  b = (S[0] * T[1] - S[1] * T[0]) / det;
  va = S[2] / det;
  vb = S[0] / det;
  cov = -S[1] / det;
  chi2 = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double r = (y[k] - a * f(x[k]) - b * g(x[k])) / err[k];
    chi2 += r * r;
  }
}
}  // namespace fit_detail

inline LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y,
                        const std::vector<double>& err) {
  fit_detail::check(x, y, err, 2, "line fit");
  LineFit f;
  double va = 0, vb = 0;
  fit_detail::solve2(
      x, y, err, [](double) { return 1.0; }, [](double v) { return v; }, f.intercept, f.slope, va,
      vb, f.covariance, f.chi2);
  f.intercept_error = std::sqrt(va);
  f.slope_error = std::sqrt(vb);
  f.dof = static_cast<int>(x.size()) - 2;
  return f;
}

inline LineFit fit_proportional(const std::vector<double>& x, const std::vector<double>& y,
                                const std::vector<double>& err) {
  fit_detail::check(x, y, err, 1, "proportional fit");
  double sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double w = 1 / (err[k] * err[k]);
    sxx += w * x[k] * x[k];
    sxy += w * x[k] * y[k];
  }
  if (!(sxx > 0)) throw ConfigError("proportional fit: every x is 0");
  LineFit f;
  f.slope = sxy / sxx;
  f.slope_error = std::sqrt(1 / sxx);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double r = (y[k] - f.slope * x[k]) / err[k];
    f.chi2 += r * r;
  }
  f.dof = static_cast<int>(x.size()) - 1;
  return f;
}

inline QuadraticFit fit_quadratic_through_origin(const std::vector<double>& x,
                                                 const std::vector<double>& y,
                                                 const std::vector<double>& err) {
  fit_detail::check(x, y, err, 2, "quadratic fit");
  QuadraticFit f;
  double va = 0, vb = 0;
  fit_detail::solve2(
      x, y, err, [](double v) { return v; }, [](double v) { return v * v; }, f.c1, f.c2, va, vb,
      f.covariance, f.chi2);
  f.c1_error = std::sqrt(va);
  f.c2_error = std::sqrt(vb);
  f.dof = static_cast<int>(x.size()) - 2;
  return f;
}

// The 99% point of the chi^2 distribution with `dof` degrees of freedom (1 to 10; beyond, the
// Wilson-Hilferty approximation): a fit whose chi^2 exceeds it does not describe the points.
inline double chi2_99(int dof) {
  static const double table[10] = {6.635,  9.210,  11.345, 13.277, 15.086,
                                   16.812, 18.475, 20.090, 21.666, 23.209};
  if (dof < 1) return 0;
  if (dof <= 10) return table[dof - 1];
  const double k = dof, z = 2.326;
  const double t = 1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k));
  return k * t * t * t;
}

// The two-sided 99% point of Student's t with `dof` degrees of freedom (standard tables, 1 to
// 30; the normal 2.576 beyond): a slope beyond t_99 standard errors is not noise.
inline double t_99(int dof) {
  static const double table[30] = {63.657, 9.925, 5.841, 4.604, 4.032, 3.707, 3.499, 3.355,
                                   3.250,  3.169, 3.106, 3.055, 3.012, 2.977, 2.947, 2.921,
                                   2.898,  2.878, 2.861, 2.845, 2.831, 2.819, 2.807, 2.797,
                                   2.787,  2.779, 2.771, 2.763, 2.756, 2.750};
  if (dof < 1) return std::numeric_limits<double>::infinity();
  return dof <= 30 ? table[dof - 1] : 2.576;
}

// The trend of a series against its index: the least-squares slope and its standard error from
// the scatter about the line (no error bars needed). Fewer than 3 values: slope 0, error 0.
struct Trend {
  double slope = 0, slope_error = 0;
  int dof = 0;
  bool significant() const { return dof > 0 && std::abs(slope) > t_99(dof) * slope_error; }
};
inline Trend trend_of(const std::vector<double>& v, std::size_t from, std::size_t to) {
  Trend t;
  if (to < from + 3) return t;
  std::vector<double> x, y, e(to - from, 1.0);
  for (std::size_t k = from; k < to; ++k) {
    x.push_back(static_cast<double>(k - from));
    y.push_back(v[k]);
  }
  const LineFit f = fit_line(x, y, e);
  t.slope = f.slope;
  t.dof = f.dof;
  t.slope_error = f.slope_error * std::sqrt(f.chi2 / f.dof);  // unit weights: scale by scatter
  return t;
}

// The 99% point of chi^2 when each point's error is itself estimated from `blocks` block means
// (nu = blocks - 1 degrees of freedom): chi^2 / dof then follows Snedecor's F(dof, nu) rather than
// chi^2_dof / dof, whose tail is heavier for few blocks (F(1, 9) = 10.56 against chi^2 6.63).
// dof x F_0.99(dof, nu) from the standard tables, dof 1 to 3 and nu 9 to 11; chi2_99 elsewhere.
inline double chi2_99_estimated_errors(int dof, int blocks) {
  static const double f99[3][3] = {{10.56, 10.04, 9.65}, {8.02, 7.56, 7.21}, {6.99, 6.55, 6.22}};
  const int nu = blocks - 1;
  if (dof < 1 || dof > 3 || nu < 9 || nu > 11) return chi2_99(dof);
  return dof * f99[dof - 1][nu - 9];
}

}  // namespace mesorock::pipeline
