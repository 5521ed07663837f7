#pragma once
// Time averages with block-averaging error bars (Flyvbjerg & Petersen 1989): the series is cut
// into blocks longer than its correlation time; the error of the mean is the standard error of the
// block means.
#include <cmath>
#include <cstddef>
#include <vector>

namespace mesorock::pipeline {

struct MeanWithError {
  double mean = 0;
  double error = 0;  // one standard error of the mean
  size_t samples = 0;
};

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
  const size_t len = series.size() / blocks;
  std::vector<double> means(blocks, 0.0);
  for (size_t b = 0; b < blocks; ++b) {
    for (size_t k = 0; k < len; ++k) means[b] += series[b * len + k];
    means[b] /= static_cast<double>(len);
  }
  double m = 0;
  for (double v : means) m += v;
  m /= static_cast<double>(blocks);
  double ss = 0;
  for (double v : means) ss += (v - m) * (v - m);
  r.error = std::sqrt(ss / static_cast<double>(blocks - 1) / static_cast<double>(blocks));
  return r;
}

}  // namespace mesorock::pipeline
