#include "quadtune/layout/spacing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "quadtune/common/random.hpp"

namespace quadtune::layout {
namespace {

std::vector<double> BruteForceNN(const std::vector<Eigen::Vector2d>& p) {
  std::vector<double> nn(p.size(), std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i != j) nn[i] = std::min(nn[i], (p[i] - p[j]).norm());
    }
  }
  return nn;
}

TEST(Spacing, MatchesBruteForceOnRandomPoints) {
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    Rng rng(seed);
    std::vector<Eigen::Vector2d> p;
    const int n = 3 + static_cast<int>(UniformInt(rng, 0, 300));
    for (int i = 0; i < n; ++i) p.emplace_back(Uniform(rng, 0, 40), Uniform(rng, -5, 5));
    const std::vector<double> expected = BruteForceNN(p);
    const std::vector<double> got = NearestNeighbourDistances(p);
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t i = 0; i < got.size(); ++i) EXPECT_DOUBLE_EQ(got[i], expected[i]) << i;
    const SpacingStats s = MeasureSpacing(p);
    double sum = 0, mn = 1e9, mx = 0;
    for (double d : expected) sum += d, mn = std::min(mn, d), mx = std::max(mx, d);
    const double mean = sum / n;
    double var = 0;
    for (double d : expected) var += (d - mean) * (d - mean);
    EXPECT_EQ(s.count, static_cast<std::size_t>(n));
    EXPECT_NEAR(s.mean, mean, 1e-12);
    EXPECT_NEAR(s.std, std::sqrt(var / n), 1e-12);
    EXPECT_DOUBLE_EQ(s.min, mn);
    EXPECT_DOUBLE_EQ(s.max, mx);
  }
}

TEST(Spacing, SquareGridHasUnitSpacing) {
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 7; ++j) p.emplace_back(1.5 * i, 1.5 * j);
  }
  const SpacingStats s = MeasureSpacing(p);
  EXPECT_NEAR(s.mean, 1.5, 1e-12);
  EXPECT_NEAR(s.std, 0.0, 1e-12);
}

TEST(Spacing, DegenerateInputs) {
  EXPECT_EQ(MeasureSpacing({}), SpacingStats{});
  const SpacingStats one = MeasureSpacing({{1.0, 2.0}});
  EXPECT_EQ(one.count, 1u);
  EXPECT_EQ(one.mean, 0.0);
  const SpacingStats two = MeasureSpacing({{0.0, 0.0}, {3.0, 4.0}});
  EXPECT_DOUBLE_EQ(two.mean, 5.0);
  // Collinear points (a 1-dimensional triangulation).
  const SpacingStats line = MeasureSpacing({{0, 0}, {1, 0}, {3, 0}, {6, 0}});
  EXPECT_DOUBLE_EQ(line.mean, (1.0 + 1.0 + 2.0 + 3.0) / 4.0);
  // Coincident points have NN distance 0.
  const std::vector<double> dup = NearestNeighbourDistances({{0, 0}, {2, 0}, {0, 0}});
  EXPECT_EQ(dup[0], 0.0);
  EXPECT_EQ(dup[2], 0.0);
  EXPECT_DOUBLE_EQ(dup[1], 2.0);
}

}  // namespace
}  // namespace quadtune::layout
