#include "soak.hpp"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

namespace quadtune::cli {
namespace {

using Samples = std::vector<std::pair<int, double>>;

// Samples every 100 flights up to `flights`, RSS from `rss(flights done)`.
template <class Fn>
Samples Series(int flights, Fn rss) {
  Samples s;
  for (int d = 100; d <= flights; d += 100) s.emplace_back(d, rss(d));
  return s;
}

TEST(Soak, SegmentSizedJumpsBothWaysAreFlat) {
  // 30.5 MiB with a 1.9 MiB segment held now and then and one returned at the end: the pattern
  // of a mimalloc process that does not grow.
  const Samples s = Series(10000, [](int d) {
    if (d >= 6000 && d < 7000) return 32.4;
    if (d == 10000) return 28.6;
    return 30.5;
  });
  const SoakVerdict v = JudgeSoak(s, 1000);
  EXPECT_TRUE(v.flat);
  EXPECT_DOUBLE_EQ(v.low, 28.6);
  EXPECT_DOUBLE_EQ(v.high, 32.4);
  EXPECT_DOUBLE_EQ(v.first_median, 30.5);
  EXPECT_DOUBLE_EQ(v.last_median, 30.5);
  EXPECT_DOUBLE_EQ(v.max_median, 32.4);
  EXPECT_NEAR(v.growth, 0.0, 1e-12);
}

TEST(Soak, SteadyGrowthIsNotFlat) {
  // 1 KiB per flight: 8.8 MiB over the 9 000 flights after warm-up, about 25 % of 35 MiB.
  const Samples s = Series(10000, [](int d) { return 30.0 + d / 1024.0; });
  const SoakVerdict v = JudgeSoak(s, 1000);
  EXPECT_FALSE(v.flat);
  EXPECT_GT(v.growth, 0.2);
  EXPECT_GT(v.trend, 0.2);
}

TEST(Soak, GrowthHiddenByANoisyEndIsCaughtByTheTrend) {
  // Grows 15 % over 8 000 flights, then the last window dips back: the trend still sees it.
  const Samples s = Series(10000, [](int d) {
    if (d > 9000) return 30.0;
    return 30.0 + 4.5 * (d - 1000) / 8000.0;
  });
  const SoakVerdict v = JudgeSoak(s, 1000);
  EXPECT_FALSE(v.flat);
  EXPECT_LE(v.growth, 0.05);
  EXPECT_GT(v.trend, 0.05);
}

TEST(Soak, SamplesBeforeWarmUpAreIgnored) {
  const Samples s = Series(4000, [](int d) { return d < 2000 ? 10.0 + d / 100.0 : 40.0; });
  const SoakVerdict v = JudgeSoak(s, 2000);
  EXPECT_TRUE(v.flat);
  EXPECT_DOUBLE_EQ(v.low, 40.0);
  EXPECT_DOUBLE_EQ(v.trend, 0.0);
  EXPECT_TRUE(JudgeSoak({}, 1000).flat);
}

}  // namespace
}  // namespace quadtune::cli
