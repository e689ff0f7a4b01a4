#include "quadtune/planning/ipopt/min_jerk_problem.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "../config_error_util.hpp"
#include "analytic_fields.hpp"
#include "quadtune/planning/esdf.hpp"

namespace quadtune::planning {
namespace {

using quadtune::test::ThrowsWithMessage;

using testing::CylinderField;
using testing::HalfSpaceField;

MinJerkBoundary Boundary() {
  MinJerkBoundary b;
  b.p0_W = Eigen::Vector3d(0.0, 0.0, 1.0);
  b.v0_W = Eigen::Vector3d(1.2, 0.3, 0.1);
  b.a0_W = Eigen::Vector3d(0.5, -0.4, 0.2);
  b.pf_W = Eigen::Vector3d(7.0, 1.0, 1.2);
  b.vf_W = Eigen::Vector3d(0.8, 0.1, 0.0);
  b.af_W = Eigen::Vector3d(0.0, 0.0, 0.0);
  return b;
}

MinJerkCostParams TightParams() {
  MinJerkCostParams p;
  p.v_max = 1.0;  // low limits so that the feasibility penalty is active
  p.a_max = 0.8;
  p.clearance = 0.8;
  p.w_col = 2.0;
  p.w_dyn = 0.5;
  return p;
}

Eigen::VectorXd PointNear(const MinJerkProblem& problem, double wiggle) {
  std::vector<Eigen::Vector3d> q;
  const int m = problem.NumPieces() - 1;
  for (int i = 1; i <= m; ++i) {
    const double f = static_cast<double>(i) / problem.NumPieces();
    q.push_back((1 - f) * problem.Boundary().p0_W + f * problem.Boundary().pf_W +
                Eigen::Vector3d(0.1 * wiggle * i, -0.2 * wiggle, 0.05 * i));
  }
  return problem.Pack(q, 0.8);
}

// Central-difference gradient of the total cost.
Eigen::VectorXd FdGradient(const MinJerkProblem& problem, const Eigen::VectorXd& z, double h) {
  Eigen::VectorXd g(z.size());
  for (int i = 0; i < z.size(); ++i) {
    Eigen::VectorXd zp = z;
    Eigen::VectorXd zm = z;
    zp(i) += h;
    zm(i) -= h;
    g(i) = (problem.Evaluate(zp, nullptr, nullptr).total -
            problem.Evaluate(zm, nullptr, nullptr).total) /
           (2 * h);
  }
  return g;
}

Eigen::MatrixXd FdHessian(const MinJerkProblem& problem, const Eigen::VectorXd& z, double h) {
  Eigen::MatrixXd hess(z.size(), z.size());
  for (int i = 0; i < z.size(); ++i) {
    Eigen::VectorXd zp = z;
    Eigen::VectorXd zm = z;
    zp(i) += h;
    zm(i) -= h;
    Eigen::VectorXd gp;
    Eigen::VectorXd gm;
    problem.Evaluate(zp, &gp, nullptr);
    problem.Evaluate(zm, &gm, nullptr);
    hess.col(i) = (gp - gm) / (2 * h);
  }
  return hess;
}

TEST(MinJerkProblem, SplineMeetsBoundaryAndIsC4AtJoints) {
  const HalfSpaceField field(Eigen::Vector3d::UnitZ(), -10.0);
  const MinJerkProblem problem(Boundary(), {1.0, 1.5, 0.8, 1.2}, {4, 4, 4, 4}, field, {});
  const Eigen::VectorXd z = PointNear(problem, 1.0);
  const Trajectory traj = problem.ToTrajectory(z);
  const auto b = Boundary();
  EXPECT_LT((traj.Position(0) - b.p0_W).norm(), 1e-9);
  EXPECT_LT((traj.Velocity(0) - b.v0_W).norm(), 1e-9);
  EXPECT_LT((traj.Acceleration(0) - b.a0_W).norm(), 1e-9);
  EXPECT_LT((traj.Position(traj.Duration()) - b.pf_W).norm(), 1e-9);
  EXPECT_LT((traj.Velocity(traj.Duration()) - b.vf_W).norm(), 1e-9);
  EXPECT_LT((traj.Acceleration(traj.Duration()) - b.af_W).norm(), 1e-9);
  const auto q = problem.InnerWaypoints(z);
  double t = 0.0;
  for (int i = 0; i + 1 < traj.NumPieces(); ++i) {
    t += traj.PieceDuration(i);
    const auto& c = traj.PieceCoefficients(i);
    const auto& next = traj.PieceCoefficients(i + 1);
    const double len = traj.PieceDuration(i);
    // Derivatives 0..4 at the end of piece i equal those at the start of piece i+1.
    for (int d = 0; d <= 4; ++d) {
      Eigen::Vector3d end = Eigen::Vector3d::Zero();
      for (int k = d; k < 6; ++k) {
        double f = 1.0;
        for (int m = 0; m < d; ++m) f *= k - m;
        end += f * c.col(k) * std::pow(len, k - d);
      }
      double f0 = 1.0;
      for (int m = 1; m <= d; ++m) f0 *= m;
      EXPECT_LT((end - f0 * next.col(d)).norm(), 1e-7 * (1.0 + end.norm()))
          << "joint " << i << " derivative " << d;
    }
    EXPECT_LT((traj.Position(t) - q[static_cast<std::size_t>(i)]).norm(), 1e-9);
  }
  EXPECT_NEAR(problem.Evaluate(z, nullptr, nullptr).jerk, traj.JerkEnergy(),
              1e-9 * traj.JerkEnergy());
}

TEST(MinJerkProblem, GradientMatchesFiniteDifferences) {
  physics::CylinderObstacle c1;
  c1.center_W = Eigen::Vector2d(2.5, 0.6);
  c1.radius = 0.4;
  physics::CylinderObstacle c2;
  c2.center_W = Eigen::Vector2d(4.5, 0.2);
  c2.radius = 0.3;
  const CylinderField field({c1, c2});
  for (int pieces : {2, 3, 5}) {
    std::vector<double> durations;
    for (int i = 0; i < pieces; ++i) durations.push_back(4.0 / pieces * (1.0 + 0.1 * i));
    const MinJerkProblem problem(Boundary(), durations,
                                 std::vector<int>(static_cast<std::size_t>(pieces), 9), field,
                                 TightParams());
    const Eigen::VectorXd z = PointNear(problem, 1.0);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    const PlanCostTerms terms = problem.Evaluate(z, &grad, &hess);
    ASSERT_GT(terms.collision, 0.0) << "collision term must be active";
    ASSERT_GT(terms.feasibility, 0.0) << "feasibility term must be active";
    const Eigen::VectorXd fd = FdGradient(problem, z, 1e-6);
    EXPECT_LT((grad - fd).norm(), 1e-5 * (1.0 + grad.norm())) << pieces << " pieces\n"
                                                              << grad.transpose() << "\n"
                                                              << fd.transpose();
    EXPECT_LT((hess - hess.transpose()).norm(), 1e-12 * (1.0 + hess.norm()));
  }
}

TEST(MinJerkProblem, CostAndDerivativesDoNotDependOnWhereTheWorldOriginIs) {
  // The same problem 5 km from the world origin (boundary, waypoints and field moved together):
  // cost, gradient and Hessian must agree with the problem near the origin to rounding of their
  // own size. Positions enter relative to the start; in world coordinates the jerk energy is a
  // difference of products of size |p|² and loses |p|²/L² of its digits.
  const Eigen::Vector3d normal = Eigen::Vector3d(0.2, -1.0, 0.1).normalized();
  const Eigen::Vector3d shift(4000.0, -3000.0, 20.0);
  const HalfSpaceField near_field(normal, -0.3);
  const HalfSpaceField far_field(normal, -0.3 + normal.dot(shift));
  MinJerkBoundary far = Boundary();
  far.p0_W += shift;
  far.pf_W += shift;
  for (int pieces : {2, 4, 7}) {
    std::vector<double> durations;
    for (int i = 0; i < pieces; ++i) durations.push_back(4.0 / pieces * (1.0 + 0.1 * i));
    const std::vector<int> samples(static_cast<std::size_t>(pieces), 9);
    const MinJerkProblem near_problem(Boundary(), durations, samples, near_field, TightParams());
    const MinJerkProblem far_problem(far, durations, samples, far_field, TightParams());
    const Eigen::VectorXd z_near = PointNear(near_problem, 1.0);
    Eigen::VectorXd z_far = z_near;
    const int m = pieces - 1;
    for (int a = 0; a < 3; ++a) z_far.segment(a * m, m).array() += shift(a);
    Eigen::VectorXd g_near, g_far;
    Eigen::MatrixXd h_near, h_far;
    const PlanCostTerms t_near = near_problem.Evaluate(z_near, &g_near, &h_near);
    const PlanCostTerms t_far = far_problem.Evaluate(z_far, &g_far, &h_far);
    ASSERT_GT(t_near.collision, 0.0);
    ASSERT_GT(t_near.feasibility, 0.0);
    EXPECT_LT(std::abs(t_far.total - t_near.total), 1e-12 * t_near.total) << pieces;
    EXPECT_LT(std::abs(t_far.jerk - t_near.jerk), 1e-12 * t_near.jerk) << pieces;
    EXPECT_LT((g_far - g_near).norm(), 1e-11 * g_near.norm()) << pieces;
    EXPECT_LT((h_far - h_near).norm(), 1e-11 * h_near.norm()) << pieces;
    // The trajectory is the same curve, moved.
    const Trajectory tr_near = near_problem.ToTrajectory(z_near);
    const Trajectory tr_far = far_problem.ToTrajectory(z_far);
    for (double t = 0.0; t <= tr_near.Duration(); t += 0.1) {
      EXPECT_LT((tr_far.Position(t) - shift - tr_near.Position(t)).norm(), 1e-9) << t;
      EXPECT_LT((tr_far.Acceleration(t) - tr_near.Acceleration(t)).norm(), 1e-9) << t;
    }
  }
}

TEST(MinJerkProblem, HessianMatchesFiniteDifferencesForAffineField) {
  // With an affine distance field the Gauss–Newton drop (∇²d) is zero: the Hessian is exact.
  const HalfSpaceField field(Eigen::Vector3d(0.2, -1.0, 0.1), -0.3);
  for (int pieces : {2, 4}) {
    std::vector<double> durations;
    for (int i = 0; i < pieces; ++i) durations.push_back(4.0 / pieces * (1.0 + 0.1 * i));
    const MinJerkProblem problem(Boundary(), durations,
                                 std::vector<int>(static_cast<std::size_t>(pieces), 9), field,
                                 TightParams());
    const Eigen::VectorXd z = PointNear(problem, 2.0);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    const PlanCostTerms terms = problem.Evaluate(z, &grad, &hess);
    ASSERT_GT(terms.collision, 0.0);
    ASSERT_GT(terms.feasibility, 0.0);
    const Eigen::MatrixXd fd = FdHessian(problem, z, 1e-6);
    EXPECT_LT((hess - fd).norm(), 1e-5 * (1.0 + hess.norm())) << pieces << " pieces\n"
                                                              << hess << "\n\n"
                                                              << fd;
    EXPECT_LT((grad - FdGradient(problem, z, 1e-6)).norm(), 1e-5 * (1.0 + grad.norm()));
  }
}

TEST(MinJerkProblem, HessianMatchesFiniteDifferencesForCylinderField) {
  // The collision term's Hessian is exact (∇²d of the field's C² soft-min distance included).
  physics::CylinderObstacle c1;
  c1.center_W = Eigen::Vector2d(2.5, 0.6);
  c1.radius = 0.4;
  physics::CylinderObstacle c2;
  c2.center_W = Eigen::Vector2d(3.2, -0.4);
  c2.radius = 0.3;
  physics::CylinderObstacle c3;
  c3.center_W = Eigen::Vector2d(4.5, 0.2);
  c3.radius = 0.3;
  const CylinderField field({c1, c2, c3});
  for (int pieces : {2, 3, 5}) {
    std::vector<double> durations;
    for (int i = 0; i < pieces; ++i) durations.push_back(4.0 / pieces * (1.0 + 0.1 * i));
    const MinJerkProblem problem(Boundary(), durations,
                                 std::vector<int>(static_cast<std::size_t>(pieces), 9), field,
                                 TightParams());
    const Eigen::VectorXd z = PointNear(problem, 1.0);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    const PlanCostTerms terms = problem.Evaluate(z, &grad, &hess);
    ASSERT_GT(terms.collision, 0.0);
    ASSERT_GT(terms.feasibility, 0.0);
    const Eigen::MatrixXd fd = FdHessian(problem, z, 1e-6);
    EXPECT_LT((hess - fd).norm(), 1e-5 * (1.0 + hess.norm())) << pieces << " pieces\n"
                                                              << hess << "\n\n"
                                                              << fd;
    EXPECT_EQ((hess - hess.transpose()).norm(), 0.0);
  }
}

TEST(MinJerkProblem, BrakingEnvelopeDerivativesMatchFiniteDifferences) {
  // A start at 3 m/s with v_max 1 m/s: the speed limit of each sample follows
  // max(v_max, 3 − 1.5 t̄); gradient and Hessian stay exact.
  const HalfSpaceField field(Eigen::Vector3d(0.2, -1.0, 0.1), -0.3);
  MinJerkBoundary boundary = Boundary();
  boundary.v0_W = Eigen::Vector3d(2.9, 0.6, 0.3);
  MinJerkCostParams params = TightParams();
  params.brake_from_speed = boundary.v0_W.norm();
  params.braking_deceleration = 1.5;
  for (int pieces : {2, 4}) {
    std::vector<double> durations;
    for (int i = 0; i < pieces; ++i) durations.push_back(4.0 / pieces * (1.0 + 0.1 * i));
    const MinJerkProblem problem(
        boundary, durations, std::vector<int>(static_cast<std::size_t>(pieces), 9), field, params);
    const Eigen::VectorXd z = PointNear(problem, 2.0);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    const PlanCostTerms terms = problem.Evaluate(z, &grad, &hess);
    ASSERT_GT(terms.feasibility, 0.0);
    EXPECT_LT((grad - FdGradient(problem, z, 1e-6)).norm(), 1e-5 * (1.0 + grad.norm()));
    const Eigen::MatrixXd fd = FdHessian(problem, z, 1e-6);
    EXPECT_LT((hess - fd).norm(), 1e-5 * (1.0 + hess.norm())) << pieces << " pieces";
  }
}

TEST(MinJerkProblem, BrakingEnvelopeOnlyRelaxesTheSpeedLimit) {
  // The same point costs less under the envelope (its early samples may fly faster than v_max),
  // and exactly the same when the start is not above v_max (the envelope is then off).
  const HalfSpaceField field(Eigen::Vector3d(0.2, -1.0, 0.1), -0.3);
  MinJerkBoundary fast = Boundary();
  fast.v0_W = Eigen::Vector3d(2.9, 0.6, 0.3);
  const std::vector<double> durations{1.0, 1.2, 1.4};
  const std::vector<int> samples{9, 9, 9};
  MinJerkCostParams plain = TightParams();
  MinJerkCostParams braking = plain;
  braking.brake_from_speed = fast.v0_W.norm();
  braking.braking_deceleration = 1.5;
  const MinJerkProblem a(fast, durations, samples, field, plain);
  const MinJerkProblem b(fast, durations, samples, field, braking);
  const Eigen::VectorXd z = PointNear(a, 1.0);
  const double fa = a.Evaluate(z, nullptr, nullptr).feasibility;
  const double fb = b.Evaluate(z, nullptr, nullptr).feasibility;
  EXPECT_GT(fa, 0.0);
  EXPECT_LT(fb, fa);
  MinJerkCostParams slow_start = braking;
  slow_start.brake_from_speed = 0.5 * plain.v_max;
  const MinJerkProblem c(fast, durations, samples, field, slow_start);
  EXPECT_EQ(c.Evaluate(z, nullptr, nullptr).total, a.Evaluate(z, nullptr, nullptr).total);
}

TEST(CylinderField, SmoothDistanceDerivativesMatchFiniteDifferences) {
  physics::CylinderObstacle c1;
  c1.center_W = Eigen::Vector2d(0.0, 0.0);
  c1.radius = 0.3;
  c1.z_max = 2.0;
  physics::CylinderObstacle c2;
  c2.center_W = Eigen::Vector2d(1.0, 0.1);
  c2.radius = 0.2;
  c2.z_max = 3.0;
  const CylinderField field({c1, c2});
  const double h = 1e-6;
  // Free space, near the ridge between the two, above a cap (corner region), inside a cylinder.
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(-0.5, 0.4, 1.0), Eigen::Vector3d(0.52, 0.06, 1.0),
        Eigen::Vector3d(0.5, 0.2, 1.5), Eigen::Vector3d(0.45, 0.0, 2.2),
        Eigen::Vector3d(0.1, 0.05, 1.0)}) {
    Eigen::Vector3d grad;
    Eigen::Matrix3d hess;
    const double d = field.EvaluateWithHessian(p, &grad, &hess);
    EXPECT_LE(d, field.Evaluate(p, nullptr) + 1e-15) << "never above the exact distance";
    EXPECT_GE(d, field.Evaluate(p, nullptr) - field.Smoothing() * std::log(2.0) - 1e-12);
    Eigen::Vector3d fd_grad;
    Eigen::Matrix3d fd_hess;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(i);
      Eigen::Vector3d gp;
      Eigen::Vector3d gm;
      Eigen::Matrix3d unused;
      fd_grad(i) = (field.EvaluateWithHessian(p + e, &gp, &unused) -
                    field.EvaluateWithHessian(p - e, &gm, &unused)) /
                   (2 * h);
      fd_hess.col(i) = (gp - gm) / (2 * h);
    }
    EXPECT_LT((grad - fd_grad).norm(), 1e-7) << p.transpose();
    EXPECT_LT((hess - fd_hess).norm(), 1e-5 * (1.0 + hess.norm())) << p.transpose() << "\n"
                                                                   << hess << "\n\n"
                                                                   << fd_hess;
    EXPECT_LT((hess - hess.transpose()).norm(), 1e-12);
  }
}

TEST(CylinderField, DefaultEvaluateWithHessianIsGaussNewton) {
  // A field without its own curvature: the default reports Evaluate() and a zero Hessian.
  const HalfSpaceField field(Eigen::Vector3d(0.0, 1.0, 0.0), 0.5);
  const Eigen::Vector3d p(0.3, 2.0, 1.0);
  Eigen::Vector3d grad;
  Eigen::Matrix3d hess = Eigen::Matrix3d::Ones();
  EXPECT_EQ(field.EvaluateWithHessian(p, &grad, &hess), field.Evaluate(p, nullptr));
  EXPECT_EQ(grad, Eigen::Vector3d(0.0, 1.0, 0.0));
  EXPECT_EQ(hess, Eigen::Matrix3d::Zero());
}

TEST(MinJerkProblem, HessianOfJerkAndTimeTermsIsExact) {
  // No active penalty: f = w_smooth τ^-5 bᵀH̄b + w_time ΣT̄ (ln τ)², Hessian exact.
  const HalfSpaceField field(Eigen::Vector3d::UnitZ(), -100.0);
  MinJerkCostParams params;
  params.v_max = 100.0;
  params.a_max = 100.0;
  const MinJerkProblem problem(Boundary(), {1.0, 1.2, 0.9}, {5, 5, 5}, field, params);
  const Eigen::VectorXd z = PointNear(problem, 1.0);
  Eigen::VectorXd grad;
  Eigen::MatrixXd hess;
  problem.Evaluate(z, &grad, &hess);
  EXPECT_LT((hess - FdHessian(problem, z, 1e-6)).norm(), 1e-6 * (1.0 + hess.norm()));
}

// Same bits: two doubles (or all entries of two matrices) are equal as stored, NaN and −0 apart.
template <typename Matrix>
bool SameBits(const Matrix& a, const Matrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

TEST(MinJerkProblem, ValueCacheGivesTheSameBitsAndIsUsedOnlyForItsProblemAndPoint) {
  // A distance field with skipped samples (beyond the clearance), active ones and samples in
  // the obstacles: two pillars across the straight line from start to goal.
  const Eigen::Vector3i dims(90, 40, 30);
  const Eigen::Vector3d origin(-0.5, -2.0, 0.0);
  const double res = 0.1;
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()), 0);
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        const Eigen::Vector3d c = origin + res * (Eigen::Vector3d(x, y, z).array() + 0.5).matrix();
        const bool pillar = (c.head<2>() - Eigen::Vector2d(2.5, 0.4)).norm() < 0.35 ||
                            (c.head<2>() - Eigen::Vector2d(5.0, 0.7)).norm() < 0.3;
        occ[static_cast<std::size_t>(x + dims.x() * (y + dims.y() * z))] = pillar ? 1 : 0;
      }
    }
  }
  const Esdf field = Esdf::FromOccupancy(origin, res, dims, occ);
  const MinJerkProblem a(Boundary(), {1.5, 1.7, 1.9, 2.1}, {9, 9, 9, 9}, field, TightParams());
  MinJerkCostParams other_params = TightParams();
  other_params.w_col = 7.0;
  const MinJerkProblem b(Boundary(), {1.5, 1.7, 1.9, 2.1}, {9, 9, 9, 9}, field, other_params);

  for (const double wiggle : {0.0, 1.0, -2.0}) {
    const Eigen::VectorXd z = PointNear(a, wiggle);
    Eigen::VectorXd z2 = z;
    z2(1) += 0.05;
    Eigen::VectorXd g_ref, g;
    Eigen::MatrixXd h_ref, h;
    const PlanCostTerms ref = a.Evaluate(z, &g_ref, &h_ref);
    ASSERT_GT(ref.collision, 0.0) << "wiggle " << wiggle;
    // Value first, then derivatives at the same z from the cache, as Ipopt asks for them.
    MinJerkProblem::ValueCache cache;
    const PlanCostTerms value = a.Evaluate(z, nullptr, nullptr, &cache);
    const PlanCostTerms with_derivatives = a.Evaluate(z, &g, &h, &cache);
    EXPECT_EQ(std::memcmp(&value, &ref, sizeof ref), 0) << "wiggle " << wiggle;
    EXPECT_EQ(std::memcmp(&with_derivatives, &ref, sizeof ref), 0) << "wiggle " << wiggle;
    EXPECT_TRUE(SameBits(g, g_ref) && SameBits(h, h_ref)) << "wiggle " << wiggle;
    // Gradient only.
    Eigen::VectorXd g_only;
    a.Evaluate(z, &g_only, nullptr, &cache);
    EXPECT_TRUE(SameBits(g_only, g_ref)) << "wiggle " << wiggle;

    // The cache holds z for problem a: another point, or another problem at z, is evaluated
    // afresh (and refills the cache).
    Eigen::VectorXd g2_ref, g2;
    Eigen::MatrixXd h2_ref, h2;
    const PlanCostTerms ref2 = a.Evaluate(z2, &g2_ref, &h2_ref);
    const PlanCostTerms at_z2 = a.Evaluate(z2, &g2, &h2, &cache);
    EXPECT_EQ(std::memcmp(&at_z2, &ref2, sizeof ref2), 0) << "wiggle " << wiggle;
    EXPECT_TRUE(SameBits(g2, g2_ref) && SameBits(h2, h2_ref)) << "wiggle " << wiggle;
    a.Evaluate(z, nullptr, nullptr, &cache);
    Eigen::VectorXd gb_ref, gb;
    Eigen::MatrixXd hb_ref, hb;
    const PlanCostTerms ref_b = b.Evaluate(z, &gb_ref, &hb_ref);
    const PlanCostTerms at_b = b.Evaluate(z, &gb, &hb, &cache);
    EXPECT_NE(ref_b.total, ref.total);
    EXPECT_EQ(std::memcmp(&at_b, &ref_b, sizeof ref_b), 0) << "wiggle " << wiggle;
    EXPECT_TRUE(SameBits(gb, gb_ref) && SameBits(hb, hb_ref)) << "wiggle " << wiggle;
  }
}

TEST(MinJerkProblem, RejectsBadInput) {
  const HalfSpaceField field(Eigen::Vector3d::UnitZ(), 0.0);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { MinJerkProblem(Boundary(), {}, {}, field, {}); }, {"need >= 1 piece"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        MinJerkProblem(Boundary(), {1.0, -1.0}, {3, 3}, field, {});
      },
      {"nominal duration", "finite and > 0"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        MinJerkProblem(Boundary(), {1.0, 1.0}, {3}, field, {});
      },
      {"one sample count per piece"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        MinJerkProblem(Boundary(), {1.0, 1.0}, {3, 0}, field, {});
      },
      {"samples_per_piece must be >= 1"}));
  MinJerkCostParams bad;
  bad.clearance = 0.0;
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        MinJerkProblem(Boundary(), {1.0, 1.0}, {3, 3}, field, bad);
      },
      {"weights/limits out of range"}));
}

}  // namespace
}  // namespace quadtune::planning
