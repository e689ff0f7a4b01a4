// Known values of quadtune's own draws (common/random.hpp), pinned so that a change of the
// algorithm (or a platform whose results differ) shows as a failure. The integer draws and the
// uniform draws are exact on every platform; the normal draws go through std::log and std::cos,
// whose last bit may differ between C libraries, so they are pinned to 1e-12.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "quadtune/common/random.hpp"

namespace quadtune {
namespace {

TEST(RandomKnownValues, Mix64IsSplitMix64) {
  // SplitMix64's first output for state 0 (the reference generator's published first value).
  EXPECT_EQ(Mix64(0), 0xe220a8397b1dcdafULL);
  EXPECT_EQ(DeriveSeed(0, {}), Mix64(0));
}

TEST(RandomKnownValues, DeriveSeed) {
  EXPECT_EQ(DeriveSeed(1, {2, 3}), 9266517659686039421ULL);
  EXPECT_EQ(DeriveSeed(42, {0}), 5043374705829640723ULL);
}

TEST(RandomKnownValues, Uniform01UsesTheTop53Bits) {
  // The 10000th output of a default-seeded std::mt19937_64 is fixed by the C++ standard.
  Rng r;
  r.discard(9999);
  EXPECT_EQ(Uniform01(r), static_cast<double>(9981545732273789042ULL >> 11) * 0x1.0p-53);
}

TEST(RandomKnownValues, Uniform01) {
  Rng r(2024);
  EXPECT_EQ(Uniform01(r), 0x1.39b1c9e957cb2p-1);
  EXPECT_EQ(Uniform01(r), 0x1.96e50634f5cdbp-1);
  EXPECT_EQ(Uniform01(r), 0x1.10086ce6c6f18p-2);
}

TEST(RandomKnownValues, UniformScalesUniform01) {
  Rng a(2024), b(2024);
  EXPECT_EQ(Uniform(a, -1.0, 3.0), -1.0 + 4.0 * Uniform01(b));
}

TEST(RandomKnownValues, UniformInt) {
  Rng r(11);
  for (const std::int64_t expected : {9, 7, 6, 1, 2, 3}) EXPECT_EQ(UniformInt(r, -3, 9), expected);
  Rng full(11);
  EXPECT_EQ(UniformInt(full, std::numeric_limits<std::int64_t>::min(),
                       std::numeric_limits<std::int64_t>::max()),
            3056867377872225267LL);
}

TEST(RandomKnownValues, StandardNormal) {
  Rng r(7);
  for (const double expected : {0.71302983388758112, 1.6105563141402486, 1.8610639876437933}) {
    EXPECT_NEAR(StandardNormal(r), expected, 1e-12);
  }
}

TEST(RandomKnownValues, Normal) {
  Rng r(7);
  for (const double expected : {2.3565149169437904, 2.8052781570701244, 2.9305319938218966}) {
    EXPECT_NEAR(Normal(r, 2.0, 0.5), expected, 1e-12);
  }
}

}  // namespace
}  // namespace quadtune
