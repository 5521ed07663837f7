// The steady tests of pipeline/flow/statistics.h: the sweep's halves_agree on block series, and
// steady_halves, which cuts a run's sampled series (rockflow run's region flow rates) into blocks
// first.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "pipeline/flow/statistics.h"

using mesorock::pipeline::halves_agree;
using mesorock::pipeline::steady_halves;
using mesorock::pipeline::SteadyHalves;

namespace {

// n samples of mean(k) plus Gaussian noise of `sigma`, seeded.
template <class Mean>
std::vector<double> noisy(size_t n, Mean mean, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, sigma);
  std::vector<double> v(n);
  for (size_t k = 0; k < n; ++k) v[k] = mean(k) + g(rng);
  return v;
}

}  // namespace

TEST(Statistics, HalvesAgreeWithinTheToleranceOrTheNoise) {
  EXPECT_TRUE(halves_agree({10, 10, 10, 10.4, 10.4, 10.4}, 3, 0.05));   // 4% apart, no noise
  EXPECT_FALSE(halves_agree({10, 10, 10, 10.6, 10.6, 10.6}, 3, 0.05));  // 6% apart, no noise
  EXPECT_TRUE(halves_agree({5, 15, 10, 16, 6, 11}, 3, 0.05));           // 10% apart, noisy
  EXPECT_FALSE(halves_agree({10, 10, 10, 10}, 3, 0.05));                // too short to tell
}

TEST(Statistics, SteadyHalvesFindsARampAndPassesAPlateau) {
  // A flow spinning up: the mean grows by half over the series, the noise 2% of it.
  const auto ramp = noisy(
      200, [](size_t k) { return 100.0 + 0.25 * static_cast<double>(k); }, 2.0, 1);
  const SteadyHalves r = steady_halves(ramp, 5, 0.05);
  ASSERT_TRUE(r.judged);
  EXPECT_FALSE(r.steady);
  EXPECT_NEAR(r.halves.first, 100.0 + 0.25 * 49.5, 1.0);
  EXPECT_NEAR(r.halves.second, 100.0 + 0.25 * 149.5, 1.0);
  // The same noise about a plateau: steady, and within 5%.
  const auto plateau = noisy(
      200, [](size_t) { return 150.0; }, 2.0, 2);
  const SteadyHalves p = steady_halves(plateau, 5, 0.05);
  EXPECT_TRUE(p.judged && p.steady && p.within);
  // A plateau in noise 50 times larger: the halves differ by more than 5%, but not beyond noise.
  const auto loud = noisy(
      200, [](size_t) { return 150.0; }, 100.0, 3);
  const SteadyHalves l = steady_halves(loud, 5, 0.05);
  EXPECT_TRUE(l.steady);
  EXPECT_GT(l.halves.noise, 0.05 * 150.0);
}

TEST(Statistics, SteadyHalvesLeavesOutTheEarliestSamplesThatFillNoBlock) {
  // 23 samples in 10 blocks of 2: the first 3 (a start-up spike) are left out.
  std::vector<double> v(23, 1.0);
  v[0] = v[1] = v[2] = 1000.0;
  const SteadyHalves h = steady_halves(v, 5, 0.05);
  EXPECT_TRUE(h.judged && h.within);
  EXPECT_DOUBLE_EQ(h.halves.first, 1.0);
  EXPECT_FALSE(steady_halves(std::vector<double>(9, 1.0), 5, 0.05).judged);
}
