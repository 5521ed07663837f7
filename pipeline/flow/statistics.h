#pragma once
// Time averages with block-averaging error bars (Flyvbjerg & Petersen 1989): the series is cut
// into blocks longer than its correlation time; the error of the mean is the standard error of the
// block means.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace mesorock::pipeline {

struct MeanWithError {
  double mean = 0;
  double error = 0;  // one standard error of the mean
  size_t samples = 0;
};

// The mean of v[from, to) and its plain standard error (the series' values taken as independent:
// block means longer than the correlation time).
inline double mean_of(const std::vector<double>& v, size_t from, size_t to) {
  double s = 0;
  for (size_t k = from; k < to; ++k) s += v[k];
  return s / static_cast<double>(to - from);
}
inline double standard_error_of(const std::vector<double>& v, size_t from, size_t to) {
  const double m = mean_of(v, from, to);
  const double n = static_cast<double>(to - from);
  double ss = 0;
  for (size_t k = from; k < to; ++k) ss += (v[k] - m) * (v[k] - m);
  return n > 1 ? std::sqrt(ss / (n - 1) / n) : 0.0;
}

// The means of `blocks` equal blocks of a series: from its first sample on (the last samples that
// fill no block left out), or with `latest` up to its last (the earliest left out). Empty when the
// series has fewer samples than blocks.
inline std::vector<double> block_means(const std::vector<double>& series, size_t blocks,
                                       bool latest = false) {
  if (blocks == 0 || series.size() < blocks) return {};
  const size_t len = series.size() / blocks, from = latest ? series.size() - len * blocks : 0;
  std::vector<double> means(blocks);
  for (size_t b = 0; b < blocks; ++b)
    means[b] = mean_of(series, from + b * len, from + (b + 1) * len);
  return means;
}

inline MeanWithError block_average(const std::vector<double>& series, size_t blocks = 10) {
  MeanWithError r;
  r.samples = series.size();
  if (series.empty()) return r;
  double sum = 0;
  for (double v : series) sum += v;
  r.mean = sum / static_cast<double>(series.size());
  if (blocks < 2 || series.size() < 2 * blocks) {
    // Too short to block: plain standard error (an underestimate for correlated data).
    double ss = 0;
    for (double v : series) ss += (v - r.mean) * (v - r.mean);
    const double n = static_cast<double>(series.size());
    r.error = n > 1 ? std::sqrt(ss / (n - 1) / n) : 0.0;
    return r;
  }
  const std::vector<double> means = block_means(series, blocks);
  double m = 0;
  for (double v : means) m += v;
  m /= static_cast<double>(blocks);
  double ss = 0;
  for (double v : means) ss += (v - m) * (v - m);
  r.error = std::sqrt(ss / static_cast<double>(blocks - 1) / static_cast<double>(blocks));
  return r;
}

// The last two windows of w values of a series: their means and the noise of their difference
// (two combined standard errors, the values taken as independent block means).
struct WindowPair {
  double first = 0, second = 0, noise = 0;
  bool within(double tolerance) const {
    return std::abs(second - first) <= tolerance * std::abs(second);
  }
  bool agree(double tolerance) const {
    return within(tolerance) || std::abs(second - first) <= noise;
  }
};

inline WindowPair last_two_windows(const std::vector<double>& J, size_t w) {
  const size_t n = J.size();
  WindowPair p;
  p.first = mean_of(J, n - 2 * w, n - w);
  p.second = mean_of(J, n - w, n);
  p.noise = 2 * std::hypot(standard_error_of(J, n - 2 * w, n - w), standard_error_of(J, n - w, n));
  return p;
}

// The steady test of block series (rockflow sweep, relperm, pc): the means of the last two windows
// of w blocks agree within `tolerance` (relative to the last) or within two combined standard
// errors (noise-dominated series).
inline bool halves_agree(const std::vector<double>& J, size_t w, double tolerance) {
  if (w == 0 || J.size() < 2 * w) return false;
  return last_two_windows(J, w).agree(tolerance);
}

// a / b and its error, a and b independent.
inline MeanWithError ratio(const MeanWithError& a, const MeanWithError& b) {
  MeanWithError q;
  q.mean = a.mean / b.mean;
  q.error = std::abs(q.mean) * std::hypot(a.mean != 0 ? a.error / a.mean : 0.0, b.error / b.mean);
  return q;
}

// Least squares of u = c0 + c1 (z - zc) + c2 (z - zc)^2, weighted by 1 / err^2 when errors are
// given (err empty: unit weights, chi2 then in the units of u^2). Normal equations (3 x 3) solved
// by Cramer's rule; fitting about a centre zc inside the data keeps them well conditioned.
struct ParabolaFit {
  double c0 = 0, c1 = 0, c2 = 0;
  double c2_error = 0;  // from the weights (meaningful only with errors)
  double chi2_per_dof = 0;
};

inline ParabolaFit fit_parabola(const std::vector<double>& z, const std::vector<double>& u,
                                const std::vector<double>& err, double zc) {
  double S[5] = {0, 0, 0, 0, 0}, T[3] = {0, 0, 0};
  auto weight = [&](size_t k) { return err.empty() ? 1.0 : 1.0 / (err[k] * err[k]); };
  for (size_t k = 0; k < z.size(); ++k) {
    const double w = weight(k);
    const double d = z[k] - zc;
    double p = 1;
    for (int e = 0; e < 5; ++e) {
      S[e] += w * p;
      if (e < 3) T[e] += w * p * u[k];
      p *= d;
    }
  }
  // M = [[S0 S1 S2] [S1 S2 S3] [S2 S3 S4]]
  auto det3 = [](double a, double b, double c, double d, double e, double f, double g, double h,
                 double i) {
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  };
  const double D = det3(S[0], S[1], S[2], S[1], S[2], S[3], S[2], S[3], S[4]);
  ParabolaFit f;
  f.c0 = det3(T[0], S[1], S[2], T[1], S[2], S[3], T[2], S[3], S[4]) / D;
  f.c1 = det3(S[0], T[0], S[2], S[1], T[1], S[3], S[2], T[2], S[4]) / D;
  f.c2 = det3(S[0], S[1], T[0], S[1], S[2], T[1], S[2], S[3], T[2]) / D;
  // Variance of c2: (M^-1)_22 = (S0 S2 - S1^2) / D.
  f.c2_error = std::sqrt((S[0] * S[2] - S[1] * S[1]) / D);
  double chi2 = 0;
  for (size_t k = 0; k < z.size(); ++k) {
    const double d = z[k] - zc;
    const double res = u[k] - (f.c0 + f.c1 * d + f.c2 * d * d);
    chi2 += res * res * weight(k);
  }
  f.chi2_per_dof = z.size() > 3 ? chi2 / static_cast<double>(z.size() - 3) : 0;
  return f;
}

}  // namespace mesorock::pipeline
