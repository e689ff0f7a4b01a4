#include "quadtune/common/random.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace quadtune {
namespace {

TEST(Random, SameSeedSameSequence) {
  Rng a(42), b(42);
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(Uniform01(a), Uniform01(b));
    EXPECT_EQ(StandardNormal(a), StandardNormal(b));
    EXPECT_EQ(UniformInt(a, -3, 9), UniformInt(b, -3, 9));
  }
}

TEST(Random, KnownFirstDrawIsPlatformIndependent) {
  // std::mt19937_64's 10000th output for the default seed is fixed by the C++ standard.
  Rng r;
  r.discard(9999);
  EXPECT_EQ(r(), 9981545732273789042ULL);
}

TEST(Random, DeriveSeedSeparatesStreams) {
  EXPECT_NE(DeriveSeed(1, {0}), DeriveSeed(1, {1}));
  EXPECT_NE(DeriveSeed(1, {0, 1}), DeriveSeed(1, {1, 0}));
  EXPECT_EQ(DeriveSeed(7, {3, 4}), DeriveSeed(7, {3, 4}));
}

TEST(Random, MomentsAreRight) {
  Rng r(1);
  const int n = 200000;
  double su = 0, sn = 0, sn2 = 0;
  for (int i = 0; i < n; ++i) {
    su += Uniform01(r);
    const double z = StandardNormal(r);
    sn += z;
    sn2 += z * z;
  }
  EXPECT_NEAR(su / n, 0.5, 0.005);
  EXPECT_NEAR(sn / n, 0.0, 0.01);
  EXPECT_NEAR(sn2 / n, 1.0, 0.02);
}

TEST(Random, UniformIntCoversInclusiveRange) {
  Rng r(3);
  int seen[5] = {0, 0, 0, 0, 0};
  for (int i = 0; i < 5000; ++i) {
    const auto v = UniformInt(r, 2, 6);
    ASSERT_GE(v, 2);
    ASSERT_LE(v, 6);
    ++seen[v - 2];
  }
  for (int c : seen) EXPECT_GT(c, 800);
}

}  // namespace
}  // namespace quadtune
