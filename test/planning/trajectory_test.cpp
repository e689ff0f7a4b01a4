#include "quadtune/planning/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"

namespace quadtune::planning {
namespace {

using quadtune::test::ThrowsWithMessage;

Trajectory TwoPieces() {
  Trajectory::Coefficients c0;
  c0 << 0, 1, 0.5, 0.2, -0.1, 0.01,  //
      1, 0, 0.3, -0.2, 0.05, 0.0,    //
      2, 0.5, 0, 0, 0.02, -0.003;
  // Second piece starting where the first one ends (continuity of p, v, a only).
  const double t0 = 1.5;
  Trajectory first({t0}, {c0});
  Trajectory::Coefficients c1 = Trajectory::Coefficients::Zero();
  c1.col(0) = first.Position(t0);
  c1.col(1) = first.Velocity(t0);
  c1.col(2) = 0.5 * first.Acceleration(t0);
  c1.col(3) << 0.1, -0.1, 0.2;
  c1.col(5) << 0.001, 0.002, -0.001;
  return Trajectory({t0, 2.0}, {c0, c1});
}

TEST(Trajectory, EvaluatesPolynomialAndDerivatives) {
  const Trajectory traj = TwoPieces();
  EXPECT_EQ(traj.NumPieces(), 2);
  EXPECT_DOUBLE_EQ(traj.Duration(), 3.5);
  const auto& c = traj.PieceCoefficients(0);
  const double t = 0.7;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (int k = 0; k < 6; ++k) p += c.col(k) * std::pow(t, k);
  for (int k = 1; k < 6; ++k) v += k * c.col(k) * std::pow(t, k - 1);
  EXPECT_LT((traj.Position(t) - p).norm(), 1e-12);
  EXPECT_LT((traj.Velocity(t) - v).norm(), 1e-12);
  // Derivatives by central differences.
  const double h = 1e-5;
  for (int order = 1; order <= 3; ++order) {
    const Eigen::Vector3d fd =
        (traj.Evaluate(2.2 + h, order - 1) - traj.Evaluate(2.2 - h, order - 1)) / (2 * h);
    EXPECT_LT((traj.Evaluate(2.2, order) - fd).norm(), 1e-6) << "order " << order;
  }
}

TEST(Trajectory, ContinuousToAccelerationAtJoints) {
  const Trajectory traj = TwoPieces();
  const double joint = traj.PieceDuration(0);
  for (int order = 0; order <= 2; ++order) {
    const Eigen::Vector3d before = traj.Evaluate(joint - 1e-9, order);
    const Eigen::Vector3d after = traj.Evaluate(joint + 1e-9, order);
    EXPECT_LT((before - after).norm(), 1e-6) << "order " << order;
  }
}

TEST(Trajectory, ClampsTimeToTheDuration) {
  const Trajectory traj = TwoPieces();
  EXPECT_EQ(traj.Position(-1.0), traj.Position(0.0));
  EXPECT_EQ(traj.Position(99.0), traj.Position(traj.Duration()));
}

TEST(Trajectory, JerkEnergyMatchesQuadrature) {
  const Trajectory traj = TwoPieces();
  // 3-point Gauss–Legendre per piece: exact for the degree-4 integrand |jerk|^2.
  double integral = 0.0;
  double start = 0.0;
  const double nodes[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  const double weights[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  for (int i = 0; i < traj.NumPieces(); ++i) {
    const double len = traj.PieceDuration(i);
    for (int k = 0; k < 3; ++k) {
      const double t = start + 0.5 * len * (1.0 + nodes[k]);
      integral += 0.5 * len * weights[k] * traj.Jerk(t).squaredNorm();
    }
    start += len;
  }
  EXPECT_NEAR(traj.JerkEnergy(), integral, 1e-8 * (1.0 + integral));
}

TEST(Trajectory, SamplesIncludeBothEnds) {
  const Trajectory traj = TwoPieces();
  const auto samples = traj.Sample(0.4);
  ASSERT_GE(samples.size(), 2U);
  EXPECT_EQ(samples.front().t, 0.0);
  EXPECT_EQ(samples.back().t, traj.Duration());
  for (std::size_t k = 1; k < samples.size(); ++k) EXPECT_GT(samples[k].t, samples[k - 1].t);
  EXPECT_GT(traj.Length(0.01), 0.0);
  EXPECT_GE(traj.MaxSpeed(0.01), traj.Velocity(0.0).norm());
}

// State() is one piece lookup for the three derivatives the post-solve check reads: the same
// bits as the separate calls, at joints, inside pieces and clamped outside the duration.
TEST(Trajectory, StateEqualsPositionVelocityAcceleration) {
  const Trajectory traj = TwoPieces();
  for (double t : {-0.5, 0.0, 0.37, traj.Duration() * 0.5, traj.Durations()[0], 1.91,
                   traj.Duration(), traj.Duration() + 2.0}) {
    Eigen::Vector3d p;
    Eigen::Vector3d v;
    Eigen::Vector3d a;
    traj.State(t, &p, &v, &a);
    EXPECT_EQ(p, traj.Position(t)) << t;
    EXPECT_EQ(v, traj.Velocity(t)) << t;
    EXPECT_EQ(a, traj.Acceleration(t)) << t;
  }
  const auto samples = traj.Sample(0.3);
  for (const auto& s : samples) {
    EXPECT_EQ(s.p_W, traj.Position(s.t));
    EXPECT_EQ(s.a_W, traj.Acceleration(s.t));
  }
}

TEST(Trajectory, RejectsBadPieces) {
  const Trajectory::Coefficients c = Trajectory::Coefficients::Zero();
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { Trajectory({}, {}); }, {"durations (0) and coefficient blocks (0)"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        Trajectory({1.0}, {c, c});
      },
      {"durations (1) and coefficient blocks (2)"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { Trajectory({0.0}, {c}); },
                                                       {"duration of piece 0", "finite and > 0"}));
  Trajectory::Coefficients bad = c;
  bad(0, 0) = std::nan("");
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { Trajectory({1.0}, {bad}); },
                                                       {"coefficients of piece 0 are not finite"}));
  EXPECT_THROW(static_cast<void>(Trajectory().Position(0.0)), InvariantError);
}

}  // namespace
}  // namespace quadtune::planning
