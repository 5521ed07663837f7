// The steady tests of pipeline/flow/statistics.h: the sweep's halves_agree on block series, and
// the same halves (last_two_windows) of the block means that block_means cuts from a run's sampled
// series (rockflow run's region flow rates).
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "pipeline/flow/statistics.h"

using mesorock::pipeline::block_means;
using mesorock::pipeline::halves_agree;
using mesorock::pipeline::last_two_windows;
using mesorock::pipeline::WindowPair;

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

TEST(Statistics, BlockHalvesFindARampAndPassAPlateau) {
  // A flow spinning up: the mean grows by half over the series, the noise 2% of it.
  const auto ramp = noisy(
      200, [](size_t k) { return 100.0 + 0.25 * static_cast<double>(k); }, 2.0, 1);
  const std::vector<double> rb = block_means(ramp, 10, true);
  ASSERT_EQ(rb.size(), 10u);
  const WindowPair r = last_two_windows(rb, 5);
  EXPECT_FALSE(r.agree(0.05));
  EXPECT_NEAR(r.first, 100.0 + 0.25 * 49.5, 1.0);
  EXPECT_NEAR(r.second, 100.0 + 0.25 * 149.5, 1.0);
  // The same noise about a plateau: steady, and within 5%.
  const auto plateau = noisy(
      200, [](size_t) { return 150.0; }, 2.0, 2);
  const WindowPair p = last_two_windows(block_means(plateau, 10, true), 5);
  EXPECT_TRUE(p.agree(0.05) && p.within(0.05));
  // A plateau in noise 50 times larger: the halves differ by more than 5%, but not beyond noise.
  const auto loud = noisy(
      200, [](size_t) { return 150.0; }, 100.0, 3);
  const WindowPair l = last_two_windows(block_means(loud, 10, true), 5);
  EXPECT_TRUE(l.agree(0.05));
  EXPECT_GT(l.noise, 0.05 * 150.0);
}

TEST(Statistics, BlockMeansLeaveOutTheSamplesThatFillNoBlock) {
  // 23 samples in 10 blocks of 2: with `latest` the first 3 (a start-up spike) are left out.
  std::vector<double> v(23, 1.0);
  v[0] = v[1] = v[2] = 1000.0;
  const std::vector<double> latest = block_means(v, 10, true);
  ASSERT_EQ(latest.size(), 10u);
  const WindowPair h = last_two_windows(latest, 5);
  EXPECT_TRUE(h.within(0.05));
  EXPECT_DOUBLE_EQ(h.first, 1.0);
  // From the first sample on (block_average's blocks), the spike fills the first block.
  EXPECT_DOUBLE_EQ(block_means(v, 10).front(), (1000.0 + 1000.0) / 2);
  EXPECT_TRUE(block_means(std::vector<double>(9, 1.0), 10, true).empty());
}
