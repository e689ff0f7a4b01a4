#include "quadtune/optimizers/design.hpp"

#include <gtest/gtest.h>

#include <set>

#include "../config_error_util.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

TEST(LatinHypercube, OnePointPerStratumInsideTheBox) {
  Rng rng(3);
  Eigen::VectorXd lo(2), hi(2);
  lo << 0.2, 0.0;
  hi << 0.6, 1.0;
  const int n = 20;
  const Eigen::MatrixXd p = LatinHypercube(n, lo, hi, rng);
  ASSERT_EQ(p.rows(), n);
  for (int j = 0; j < 2; ++j) {
    std::set<int> strata;
    for (int i = 0; i < n; ++i) {
      EXPECT_GE(p(i, j), lo[j]);
      EXPECT_LE(p(i, j), hi[j]);
      strata.insert(static_cast<int>((p(i, j) - lo[j]) / (hi[j] - lo[j]) * n));
    }
    EXPECT_EQ(strata.size(), static_cast<std::size_t>(n));
  }
}

TEST(LatinHypercube, SameSeedSameDesign) {
  Rng a(7), b(7);
  const Eigen::VectorXd lo = Eigen::VectorXd::Zero(3), hi = Eigen::VectorXd::Ones(3);
  EXPECT_EQ(LatinHypercube(10, lo, hi, a), LatinHypercube(10, lo, hi, b));
}

TEST(LatinHypercube, RejectsBadArguments) {
  Rng rng(1);
  const Eigen::VectorXd lo = Eigen::VectorXd::Zero(2), hi = Eigen::VectorXd::Ones(2);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)LatinHypercube(0, lo, hi, rng); }, {"n must be >= 1", "got 0"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)LatinHypercube(3, hi, lo, rng); }, {"lower must not exceed upper"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)UniformDesign(3, lo, Eigen::VectorXd::Ones(3), rng); }, {"same, non-zero size"}));
}

}  // namespace
}  // namespace quadtune::optimizers
