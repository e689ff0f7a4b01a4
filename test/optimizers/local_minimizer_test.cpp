#include "quadtune/optimizers/local_minimizer.hpp"

#include <gtest/gtest.h>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

double Rosen(const Eigen::VectorXd& x, Eigen::VectorXd* g) {
  const double a = 1.0 - x[0], b = x[1] - x[0] * x[0];
  if (g) {
    (*g)[0] = -2.0 * a - 400.0 * x[0] * b;
    (*g)[1] = 200.0 * b;
  }
  return a * a + 100.0 * b * b;
}

TEST(MinimizeBox, FindsRosenbrockMinimum) {
  Eigen::VectorXd x(2);
  x << -1.2, 1.0;
  BoxLbfgsOptions o;
  o.max_iterations = 200;
  const auto s = MinimizeBox(Rosen, x, Eigen::VectorXd::Constant(2, -2.0), Eigen::VectorXd::Constant(2, 2.0), o);
  EXPECT_NEAR(x[0], 1.0, 1e-3);
  EXPECT_NEAR(x[1], 1.0, 1e-3);
  EXPECT_LT(s.value, 1e-6);
}

TEST(MinimizeBox, StopsAtActiveBound) {
  Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 0.5);
  auto f = [](const Eigen::VectorXd& v, Eigen::VectorXd* g) {
    if (g) *g = 2.0 * (v - Eigen::Vector2d(3.0, 0.2));
    return (v - Eigen::Vector2d(3.0, 0.2)).squaredNorm();
  };
  MinimizeBox(f, x, Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2));
  EXPECT_DOUBLE_EQ(x[0], 1.0);
  EXPECT_NEAR(x[1], 0.2, 1e-6);
}

TEST(MinimizeBox, RejectsBadOptions) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  BoxLbfgsOptions o;
  o.max_iterations = 0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { MinimizeBox(Rosen, x, x, x, o); },
                                                  "max_iterations", {"must be an integer"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { MinimizeBox(Rosen, x, Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2)); },
      {"must have the same size"}));
}

}  // namespace
}  // namespace quadtune::optimizers
